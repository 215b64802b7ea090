//! Tolerance decisions above the runner: the worst case over the tolerance box, the
//! linear stack-up (RSS) with each input's contribution, the side-by-side table of worst
//! case, RSS and Monte Carlo, and tolerance allocation. See docs/tolerancing.md.

pub mod allocation;
pub mod allocation_run;
pub mod stack_up;
pub mod table;
pub mod worst_case;
pub mod worst_case_run;
