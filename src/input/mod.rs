//! What users write, read the same way everywhere: files read with a size bound (`file`),
//! quantities with units (`units`), closed-form expressions (`expr`), and the names that
//! become columns of the result store (`columns`).

pub mod columns;
pub mod expr;
pub mod file;
pub mod units;
