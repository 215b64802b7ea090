//! A prescribed scalar of time with its rate: constant rate, or a piecewise-linear table.

#[derive(Clone, Debug, PartialEq)]
pub enum ScalarProfile {
    /// start + rate · t
    Rate { start: f64, rate: f64 },
    /// Strictly increasing times with values; clamped outside, linear inside.
    Table(Vec<(f64, f64)>),
}

impl ScalarProfile {
    pub fn value(&self, t: f64) -> f64 {
        match self {
            ScalarProfile::Rate { start, rate } => start + rate * t,
            ScalarProfile::Table(rows) => crate::math::piecewise_linear(rows, t),
        }
    }

    /// A table's times, where the rate jumps.
    pub fn knots(&self) -> Vec<f64> {
        match self {
            ScalarProfile::Rate { .. } => Vec::new(),
            ScalarProfile::Table(rows) => rows.iter().map(|r| r.0).collect(),
        }
    }

    /// Time derivative (right derivative at table knots; zero outside the table).
    pub fn rate(&self, t: f64) -> f64 {
        match self {
            ScalarProfile::Rate { rate, .. } => *rate,
            ScalarProfile::Table(rows) => {
                let i = rows.partition_point(|(ti, _)| *ti <= t);
                if i == 0 || i == rows.len() {
                    0.0
                } else {
                    (rows[i].1 - rows[i - 1].1) / (rows[i].0 - rows[i - 1].0)
                }
            }
        }
    }
}
