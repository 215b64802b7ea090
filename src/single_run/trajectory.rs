//! Recorded trajectories: one row per recorded step with time, energy, every moving body's
//! pose and twist, every contact candidate's gap and impulse, every joint's reaction, every
//! drive's effort and every value probe's measure; written as CSV or Parquet. These are the
//! curves a test bench records: force against displacement is two of its columns.

use crate::integrator::Simulation;
use crate::mechanics::contact::compliant::CompliantSource;
use crate::mechanics::Motion;
use crate::probe::{reaction, Measure, Probe, ProbeKind, Transmission};
use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// Column-major table of f64 samples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    pub columns: Vec<String>,
    pub data: Vec<Vec<f64>>,
    /// What the columns after the contacts' read: joints' reactions, then measures.
    readings: Vec<Reading>,
}

/// A group of columns read off the simulation after a step.
#[derive(Clone, Debug, PartialEq)]
enum Reading {
    /// A joint's reaction on its body b: world force (N), then world torque about the
    /// joint's centre (N·m), each the last step's impulse / h.
    Reaction(Transmission),
    /// One number: a drive's effort or a value probe's measure.
    Measure(Measure),
}

const REACTION_FIELDS: [&str; 6] = ["fx", "fy", "fz", "tx", "ty", "tz"];

const BODY_FIELDS: [&str; 13] = [
    "x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz",
];
const CONTACT_FIELDS: [&str; 4] = ["gap", "pn", "pt1", "pt2"];
/// A compliant contact point's gap and force (N) on body 1 in its frame (n, t1, t2).
const COMPLIANT_FIELDS: [&str; 4] = ["gap", "fn", "ft1", "ft2"];

impl Trajectory {
    /// An empty trajectory with the columns of `sim`'s model and of the value `probes`'
    /// measures (`probe.<name>`).
    pub fn for_simulation(sim: &Simulation, probes: &[Probe]) -> Self {
        let m = &sim.model;
        let mut columns = vec!["t".to_string(), "energy".to_string()];
        for b in m.bodies.iter().filter(|b| b.motion != Motion::Fixed) {
            columns.extend(BODY_FIELDS.iter().map(|f| format!("{}.{f}", b.name)));
        }
        for &c in sim.contact_ids() {
            let base = m.candidate_name(c);
            columns.extend(CONTACT_FIELDS.iter().map(|f| format!("{base}.{f}")));
        }
        for c in &m.compliant {
            for k in 0..c.points() {
                let base = match (&c.source, c.points()) {
                    (CompliantSource::Journal(_), _) => {
                        format!("{}.ring{}", c.name(), ["-", "+"][k])
                    }
                    (_, 1) => c.name().to_string(),
                    _ => format!("{}[{k}]", c.name()),
                };
                columns.extend(COMPLIANT_FIELDS.iter().map(|f| format!("{base}.{f}")));
            }
        }
        let mut readings = Vec::new();
        let joints = (0..m.joints.len()).map(|j| (&m.joints[j].name, Transmission::of_joint(m, j)));
        let clearance = (0..m.clearance_joints.len()).map(|j| {
            (
                &m.clearance_joints[j].name,
                Transmission::of_clearance(m, j),
            )
        });
        for (name, through) in joints.chain(clearance) {
            columns.extend(REACTION_FIELDS.iter().map(|f| format!("{name}.{f}")));
            readings.push(Reading::Reaction(through));
        }
        for (j, joint) in m
            .joints
            .iter()
            .enumerate()
            .filter(|(_, j)| j.drive.is_some())
        {
            columns.push(format!("{}.effort", joint.name));
            readings.push(Reading::Measure(Measure::DriveEffort(j)));
        }
        for p in probes {
            if let ProbeKind::Value { measure, .. } = &p.kind {
                columns.push(format!("probe.{}", p.name));
                readings.push(Reading::Measure(measure.clone()));
            }
        }
        let data = vec![Vec::new(); columns.len()];
        Trajectory {
            columns,
            data,
            readings,
        }
    }

    pub fn rows(&self) -> usize {
        self.data.first().map_or(0, Vec::len)
    }

    /// Appends the current state of `sim` (its last step's impulses included).
    pub fn record(&mut self, sim: &Simulation) {
        let s = &sim.state;
        let mut row = Vec::with_capacity(self.columns.len());
        row.push(s.t);
        row.push(sim.energy());
        for (i, b) in sim.model.bodies.iter().enumerate() {
            if b.motion == Motion::Fixed {
                continue;
            }
            let p = &s.poses[i];
            let q = p.p.quaternion();
            row.extend_from_slice(&[p.x.x, p.x.y, p.x.z, q.w, q.i, q.j, q.k]);
            row.extend_from_slice(&s.v.as_slice()[6 * i..6 * i + 6]);
        }
        for (cp, imp) in sim.contact_points().iter().zip(sim.impulses()) {
            row.extend_from_slice(&[cp.gap(), imp.x, imp.y, imp.z]);
        }
        for (cp, f) in sim.compliant_points() {
            row.extend_from_slice(&[cp.gap(), f.x, f.y, f.z]);
        }
        for r in &self.readings {
            match r {
                Reading::Reaction(through) => {
                    let (f, t) = reaction(sim, through);
                    row.extend_from_slice(&[f.x, f.y, f.z, t.x, t.y, t.z]);
                }
                Reading::Measure(m) => row.push(m.value(sim)),
            }
        }
        for (col, x) in self.data.iter_mut().zip(row) {
            col.push(x);
        }
    }

    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }

    pub fn write_csv(&self, path: &Path) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
        writeln!(w, "{}", self.columns.join(","))?;
        for r in 0..self.rows() {
            let line: Vec<String> = self.data.iter().map(|c| format!("{:e}", c[r])).collect();
            writeln!(w, "{}", line.join(","))?;
        }
        w.flush()
    }

    pub fn write_parquet(&self, path: &Path) -> Result<(), parquet::errors::ParquetError> {
        let schema = Arc::new(Schema::new(
            self.columns
                .iter()
                .map(|c| Field::new(c, DataType::Float64, false))
                .collect::<Vec<_>>(),
        ));
        let arrays: Vec<ArrayRef> = self
            .data
            .iter()
            .map(|c| Arc::new(Float64Array::from(c.clone())) as ArrayRef)
            .collect();
        let batch = RecordBatch::try_new(schema.clone(), arrays)?;
        let props = WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::default()))
            .build();
        let mut w = ArrowWriter::try_new(std::fs::File::create(path)?, schema, Some(props))?;
        w.write(&batch)?;
        w.close()?;
        Ok(())
    }
}
