//! Loops over small dense systems specialised to their size.
//!
//! A joint's rows or a contact's block make systems of 1 to 6 unknowns, where loops whose
//! bound is only known at run time spend more on their control and bounds checks than on
//! the arithmetic. `sized!` gives such a loop its bound as a constant, so that the compiler
//! unrolls it; the arithmetic and its order are the same as with any bound.

/// Evaluates `$f` with `$m` bound to `$n`: as a constant for 1 to 6, so that `$f`, inlined,
/// is compiled for that size, and as given above that.
macro_rules! sized {
    ($n:expr, |$m:ident| $f:expr) => {
        match $n {
            1 => {
                let $m = 1;
                $f
            }
            2 => {
                let $m = 2;
                $f
            }
            3 => {
                let $m = 3;
                $f
            }
            4 => {
                let $m = 4;
                $f
            }
            5 => {
                let $m = 5;
                $f
            }
            6 => {
                let $m = 6;
                $f
            }
            $m => $f,
        }
    };
}

pub(crate) use sized;
