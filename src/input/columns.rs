//! The names a study's inputs and outputs take as columns of the result store: any but
//! the store's own columns.

/// Column names no input or output may take: those of the results' own columns.
pub const RESERVED: [&str; 14] = [
    "sample_id",
    "status",
    "error",
    "missing",
    "steps",
    "max_penetration",
    "max_solver_residual",
    "nonconverged_steps",
    "wall_ms",
    "batch",
    "stage",
    "level",
    "chain",
    "margin",
];

/// Why `name` cannot name an output column, if it cannot: a reserved column's name, or a
/// name that is empty.
pub fn column_name_error(name: &str) -> Option<String> {
    if name.trim().is_empty() {
        return Some("must not be empty".into());
    }
    RESERVED.contains(&name).then(|| {
        format!(
            "`{name}` is the name of one of the results' own columns ({}); choose another",
            RESERVED.join(", ")
        )
    })
}
