//! Storage that a function keeps from one call to the next on each thread (a step's or a
//! solver's scratch): taken when a call begins and put back when it ends, on every way
//! out. A nested call of the same function finds none and makes its own.

use std::cell::Cell;
use std::ops::{Deref, DerefMut};
use std::thread::LocalKey;

/// A thread's kept storage (boxed, so that taking and returning it moves a pointer).
pub type Slot<T> = Cell<Option<Box<T>>>;

/// The storage taken from a slot; dropping it puts it back.
pub struct Kept<T: 'static> {
    slot: &'static LocalKey<Slot<T>>,
    value: Option<Box<T>>,
}

/// Takes this thread's storage from `slot`, or a new one where it holds none.
pub fn take<T: Default>(slot: &'static LocalKey<Slot<T>>) -> Kept<T> {
    Kept {
        slot,
        value: Some(slot.take().unwrap_or_default()),
    }
}

impl<T> Deref for Kept<T> {
    type Target = T;
    fn deref(&self) -> &T {
        self.value.as_deref().expect("held until dropped")
    }
}

impl<T> DerefMut for Kept<T> {
    fn deref_mut(&mut self) -> &mut T {
        self.value.as_deref_mut().expect("held until dropped")
    }
}

impl<T> Drop for Kept<T> {
    fn drop(&mut self) {
        self.slot.set(self.value.take());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        static COUNTS: Slot<Vec<u32>> = const { Slot::new(None) };
    }

    /// What a call leaves is there for the next one, also after an early return; a nested
    /// call takes a fresh one and its storage is the one put back last.
    #[test]
    fn storage_is_put_back_on_every_way_out() {
        let push = |x: u32, early: bool| -> usize {
            let mut counts = take(&COUNTS);
            counts.push(x);
            if early {
                return counts.len();
            }
            counts.len()
        };
        assert_eq!(push(1, true), 1);
        assert_eq!(push(2, false), 2);
        let outer = take(&COUNTS);
        assert_eq!(push(3, false), 1, "a nested call makes its own");
        assert_eq!(*outer, vec![1, 2]);
        drop(outer);
        assert_eq!(push(4, false), 3);
    }
}
