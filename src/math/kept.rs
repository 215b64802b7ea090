//! Storage that a function keeps from one call to the next on each thread (a step's or a
//! solver's scratch): taken when a call begins and put back when it ends, on every way
//! out. A nested call of the same function finds none and makes its own.

use std::cell::{Cell, RefCell};
use std::ops::{Deref, DerefMut};
use std::thread::LocalKey;

/// A thread's kept storage (boxed, so that taking and returning it moves a pointer).
pub type Slot<T> = Cell<Option<Box<T>>>;

/// Vectors handed back on a thread once done with, for the next one it needs: lists that
/// a step makes and lets go (contact points at its end, at a projection's iterate) reuse
/// the storage of earlier ones instead of allocating.
pub type Spares<T> = RefCell<Vec<Vec<T>>>;

/// At most this many spare vectors are kept of each kind on each thread.
const SPARES: usize = 8;

/// An empty vector, in the storage of one handed back where there is one.
pub fn spare<T>(spares: &'static LocalKey<Spares<T>>) -> Vec<T> {
    let mut v = spares.with_borrow_mut(Vec::pop).unwrap_or_default();
    v.clear();
    v
}

/// A vector handed back, with the stale entries it held, for a caller that writes over
/// `n` of them: the shortest that holds as many, else the longest (an empty one where
/// none was handed back).
pub fn spare_as_left<T>(spares: &'static LocalKey<Spares<T>>, n: usize) -> Vec<T> {
    spares.with_borrow_mut(|kept| {
        let fits = |v: &Vec<T>| (v.len() < n, v.len().abs_diff(n));
        let best = (0..kept.len()).min_by_key(|&i| fits(&kept[i]));
        best.map(|i| kept.swap_remove(i)).unwrap_or_default()
    })
}

/// Keeps the storage of `v` for a later `spare`.
pub fn hand_back<T>(spares: &'static LocalKey<Spares<T>>, v: Vec<T>) {
    // a list that never held anything has no storage to keep
    if v.capacity() == 0 {
        return;
    }
    spares.with_borrow_mut(|kept| {
        if kept.len() < SPARES {
            kept.push(v);
        }
    });
}

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

    thread_local! {
        static LISTS: Spares<u32> = const { RefCell::new(Vec::new()) };
    }

    /// A vector handed back comes out again empty, in the same storage; with none kept a
    /// new one is made.
    #[test]
    fn spares_are_handed_out_empty_in_kept_storage() {
        let mut v = spare(&LISTS);
        assert_eq!(v.capacity(), 0, "none kept yet");
        v.extend([1, 2, 3]);
        let at = v.as_ptr();
        hand_back(&LISTS, v);
        let again = spare(&LISTS);
        assert_eq!((again.as_ptr(), again.len()), (at, 0));
        assert!(again.capacity() >= 3);
        assert_eq!(spare(&LISTS).capacity(), 0, "the one kept is out");
    }

    thread_local! {
        static STALE: Spares<u32> = const { RefCell::new(Vec::new()) };
    }

    /// A list to write n entries over is the shortest kept that holds n, else the
    /// longest; it keeps its entries.
    #[test]
    fn spares_to_write_over_are_the_shortest_that_fit() {
        for v in [vec![1; 2], vec![2; 9], vec![3; 5]] {
            hand_back(&STALE, v);
        }
        assert_eq!(spare_as_left(&STALE, 4), vec![3; 5]);
        assert_eq!(
            spare_as_left(&STALE, 20),
            vec![2; 9],
            "none fits: the longest"
        );
        assert_eq!(spare_as_left(&STALE, 0), vec![1; 2]);
        assert!(spare_as_left(&STALE, 0).is_empty(), "none kept");
    }
}
