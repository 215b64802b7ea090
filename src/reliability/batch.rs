//! How a rare-event algorithm meets the runner: it asks for batches of points and reads
//! their margins. Its whole state is a function of the seed and the margins of the batches
//! before, so it is replayed from the start whenever a batch comes back: a resumed,
//! sharded or re-run study asks for the same batches with the same points.

/// The stage a simulation belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    MonteCarlo,
    Subset,
    Importance,
}

impl Stage {
    pub fn name(self) -> &'static str {
        match self {
            Stage::MonteCarlo => "monte-carlo",
            Stage::Subset => "subset",
            Stage::Importance => "importance",
        }
    }

    pub fn parse(s: &str) -> Option<Stage> {
        [Stage::MonteCarlo, Stage::Subset, Stage::Importance]
            .into_iter()
            .find(|k| k.name() == s)
    }
}

/// Where one simulation sits in the algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tag {
    /// The batch, counted from 0 over the whole study.
    pub batch: u64,
    pub stage: Stage,
    /// The subset level (0 for direct sampling), or the importance-sampling round.
    pub level: u64,
    /// The Markov chain of a subset level above 0.
    pub chain: Option<u64>,
}

/// A batch the algorithm needs: simulations `first..first + points.len()` at these
/// standard-normal points.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    pub first: u64,
    pub points: Vec<Vec<f64>>,
    pub tags: Vec<Tag>,
}

/// The margins of a batch's points, or `None` while any of them is still to run. A margin
/// ≤ 0 is a failure.
pub trait Margins {
    fn of(&mut self, request: &Request) -> Option<Vec<f64>>;
}

/// A margin computed in memory (a closed-form limit state): every batch is available.
pub struct Function<F: Fn(&[f64]) -> f64>(pub F);

impl<F: Fn(&[f64]) -> f64> Margins for Function<F> {
    fn of(&mut self, request: &Request) -> Option<Vec<f64>> {
        Some(request.points.iter().map(|u| (self.0)(u)).collect())
    }
}

/// Hands out simulation ids and batch numbers in order, and stops the replay at the first
/// batch whose margins are not known yet.
pub struct Cursor<'a> {
    next_id: u64,
    next_batch: u64,
    margins: &'a mut dyn Margins,
}

impl<'a> Cursor<'a> {
    pub fn new(margins: &'a mut dyn Margins) -> Self {
        Cursor {
            next_id: 0,
            next_batch: 0,
            margins,
        }
    }

    /// Simulations asked for so far.
    pub fn simulations(&self) -> u64 {
        self.next_id
    }

    /// The batch number the next `evaluate` will have.
    pub fn batch(&self) -> u64 {
        self.next_batch
    }

    /// The margins of `points`; `Err` with the batch to run when they are not known.
    /// `place(k)` gives point k's stage, level and chain.
    pub fn evaluate(
        &mut self,
        points: Vec<Vec<f64>>,
        place: impl Fn(usize) -> (Stage, u64, Option<u64>),
    ) -> Result<Vec<f64>, Request> {
        let batch = self.next_batch;
        let tags = (0..points.len())
            .map(|k| {
                let (stage, level, chain) = place(k);
                Tag {
                    batch,
                    stage,
                    level,
                    chain,
                }
            })
            .collect();
        let request = Request {
            first: self.next_id,
            points,
            tags,
        };
        match self.margins.of(&request) {
            Some(m) => {
                debug_assert_eq!(m.len(), request.points.len());
                self.next_id += request.points.len() as u64;
                self.next_batch += 1;
                Ok(m)
            }
            None => Err(request),
        }
    }
}
