//! A parameter as a drawing states it (nominal, band, process capability), the cost of its
//! tolerance, and the box a worst-case search explores.

use super::build::at;
use super::schema::{AllocationSpec, CostSpec};
use super::{statistics, AllocationTarget, Distribution, Output, Parameter, StudyError};
use crate::input::units::{Dim, DisplayUnit};
use crate::scene::error::line;
use serde_saphyr::Spanned;

/// `55 mm +0.05/−0.02, Cp 1.33`: a nominal value with its band [nominal − minus,
/// nominal + plus], drawn normal (σ = band / (6 Cp), centred on the band) or uniform.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawing {
    pub nominal: f64,
    pub plus: f64,
    pub minus: f64,
    /// `None` for a uniform band.
    pub cp: Option<f64>,
}

impl Drawing {
    /// The distribution the drawing means.
    pub fn distribution(&self) -> Distribution {
        match self.cp {
            Some(cp) => Distribution::Normal {
                mean: self.nominal + 0.5 * (self.plus - self.minus),
                sd: (self.plus + self.minus) / (6.0 * cp),
            },
            None => Distribution::Uniform {
                lower: self.nominal - self.minus,
                upper: self.nominal + self.plus,
            },
        }
    }

    /// The drawing re-toleranced by `ratio`: the nominal stays, both sides of the band
    /// scale.
    pub fn scaled(&self, ratio: f64) -> Drawing {
        Drawing {
            plus: self.plus * ratio,
            minus: self.minus * ratio,
            ..self.clone()
        }
    }

    /// As a drawing writes it, in `unit`.
    pub fn describe(&self, unit: &DisplayUnit) -> String {
        let v = |x: f64| trim(unit.of(x));
        let band = if self.plus == self.minus {
            format!("±{}", v(self.plus))
        } else {
            format!("+{}/−{}", v(self.plus), v(self.minus))
        };
        let u = if unit.label.is_empty() {
            String::new()
        } else {
            format!(" {}", unit.label)
        };
        let law = match self.cp {
            Some(cp) => format!("normal, Cp {}", trim(cp)),
            None => "uniform".into(),
        };
        format!("{} {band}{u} ({law})", v(self.nominal))
    }
}

/// A number with at most 6 significant digits and no trailing zeros.
fn trim(x: f64) -> String {
    let s = format!("{:.*}", decimals(x), x);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn decimals(x: f64) -> usize {
    if x == 0.0 || !x.is_finite() {
        return 0;
    }
    (5 - x.abs().log10().floor() as i64).clamp(0, 12) as usize
}

/// The cost of a tolerance t: a + b t₀ / t, with t₀ the tolerance the study states today.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    pub a: f64,
    pub b: f64,
}

impl Default for Cost {
    fn default() -> Self {
        Cost { a: 0.0, b: 1.0 }
    }
}

impl Cost {
    /// The cost at `ratio` = t / t₀.
    pub fn at(&self, ratio: f64) -> f64 {
        self.a + self.b / ratio
    }
}

/// Default half-width of the worst-case box, in σ, for an unbounded input.
pub const BOX_SIGMAS: f64 = 3.0;

impl Parameter {
    /// The unit the parameter is shown in: mm for a length of a few mm.
    pub fn display_unit(&self) -> DisplayUnit {
        let (m, s) = self.distribution.moments();
        match Dim::of_unit(&self.unit) {
            // a tenth of the size: 120 mm reads in mm, as a drawing writes it
            Some(d) => DisplayUnit::auto(d, 0.1 * m.abs().max(s)),
            None => DisplayUnit {
                label: self.unit.clone(),
                per_si: 1.0,
            },
        }
    }

    /// The parameter as the study states it: the drawing's words, or the distribution.
    pub fn stated(&self) -> String {
        let unit = self.display_unit();
        if let Some(d) = &self.drawing {
            return d.describe(&unit);
        }
        let u = if unit.label.is_empty() {
            String::new()
        } else {
            format!(" {}", unit.label)
        };
        // a value with its unit; an infinite bound as ∞
        let v = |x: f64| {
            if x.is_infinite() {
                if x > 0.0 {
                    "∞".to_string()
                } else {
                    "−∞".to_string()
                }
            } else {
                format!("{}{u}", trim(unit.of(x)))
            }
        };
        match self.distribution {
            Distribution::Normal { mean, sd } => format!("normal, mean {}, σ {}", v(mean), v(sd)),
            Distribution::TruncatedNormal {
                mean,
                sd,
                lower,
                upper,
            } => format!(
                "normal, mean {}, σ {}, truncated to [{}, {}]",
                v(mean),
                v(sd),
                v(lower),
                v(upper)
            ),
            Distribution::Uniform { lower, upper } => {
                format!("uniform over [{}, {}]", v(lower), v(upper))
            }
            Distribution::Lognormal { .. } => {
                let (m, s) = self.distribution.moments();
                format!("lognormal, mean {}, σ {}", v(m), v(s))
            }
            Distribution::Triangular { lower, mode, upper } => {
                format!("triangular, [{}, {}], mode {}", v(lower), v(upper), v(mode))
            }
            Distribution::Fixed(x) => format!("fixed at {}", v(x)),
        }
    }

    /// The interval a worst-case search explores: a drawing's band, a bounded support, or
    /// ± `sigmas` σ about the mean (within the support) for an unbounded input.
    pub fn tolerance_box(&self, sigmas: f64) -> (f64, f64) {
        if let Some(d) = &self.drawing {
            return (d.nominal - d.minus, d.nominal + d.plus);
        }
        match self.distribution {
            Distribution::Normal { mean, sd } => (mean - sigmas * sd, mean + sigmas * sd),
            Distribution::TruncatedNormal {
                mean,
                sd,
                lower,
                upper,
            } => (
                (mean - sigmas * sd).max(lower),
                (mean + sigmas * sd).min(upper),
            ),
            Distribution::Uniform { lower, upper }
            | Distribution::Triangular { lower, upper, .. } => (lower, upper),
            Distribution::Lognormal { .. } => (
                self.distribution.from_standard(-sigmas),
                self.distribution.from_standard(sigmas),
            ),
            Distribution::Fixed(x) => (x, x),
        }
    }
}

/// A parameter's `cost:` block: a + b t₀ / t with a ≥ 0 and b > 0.
pub(super) fn cost(spec: Option<&Spanned<CostSpec>>, field: &str) -> Result<Cost, StudyError> {
    let Some(c) = spec else {
        return Ok(Cost::default());
    };
    let a = c.value.a.as_ref().map_or(0.0, |a| a.value);
    let b = c.value.b.as_ref().map_or(1.0, |b| b.value);
    if !(a >= 0.0 && a.is_finite()) {
        return Err(at(
            c.value.a.as_ref().and_then(line),
            format!("{field}.a"),
            format!("the fixed cost must be ≥ 0, got {a}"),
        ));
    }
    if !(b > 0.0 && b.is_finite()) {
        return Err(at(
            c.value.b.as_ref().and_then(line).or(line(c)),
            format!("{field}.b"),
            format!("the cost of today's precision must be > 0, got {b}"),
        ));
    }
    Ok(Cost { a, b })
}

/// The `allocation:` block.
pub(super) fn allocation_target(
    spec: &Spanned<AllocationSpec>,
    outputs: &[Output],
) -> Result<AllocationTarget, StudyError> {
    let v = &spec.value;
    let (cpk, ppm) = match (&v.cpk, &v.ppm) {
        (Some(c), None) => {
            if !(c.value > 0.0 && c.value.is_finite()) {
                return Err(at(
                    line(c),
                    "allocation.cpk",
                    format!("must be > 0, got {}", c.value),
                ));
            }
            (c.value, None)
        }
        (None, Some(p)) => {
            if !(p.value > 0.0 && p.value < 1e6) {
                return Err(at(
                    line(p),
                    "allocation.ppm",
                    format!("must lie in (0, 1000000), got {}", p.value),
                ));
            }
            // the normal model's one-sided rate at the nearer limit: ppm = 1e6 Φ(−3 Cpk)
            (-statistics::probit(p.value * 1e-6) / 3.0, Some(p.value))
        }
        _ => {
            return Err(at(
                line(spec),
                "allocation",
                "give `cpk` (e.g. 1.33) or `ppm` (e.g. 60), one of them",
            ))
        }
    };
    let ratio = |r: &Option<Spanned<f64>>, name: &str, default: f64| -> Result<f64, StudyError> {
        let x = r.as_ref().map_or(default, |r| r.value);
        if !(x > 0.0 && x.is_finite()) {
            return Err(at(
                r.as_ref().and_then(line),
                format!("allocation.{name}"),
                format!("a ratio of tolerances must be > 0, got {x}"),
            ));
        }
        Ok(x)
    };
    let narrowest = ratio(&v.narrowest, "narrowest", 0.1)?;
    let widest = ratio(&v.widest, "widest", 4.0)?;
    if narrowest > 1.0 || widest < 1.0 {
        return Err(at(
            line(spec),
            "allocation",
            format!("needs narrowest ≤ 1 ≤ widest (today's tolerances must be allowed), got {narrowest} and {widest}"),
        ));
    }
    let limited = |k: usize| outputs[k].lower.is_some() || outputs[k].upper.is_some();
    let chosen: Vec<usize> = match &v.outputs {
        None => (0..outputs.len()).filter(|&k| limited(k)).collect(),
        Some(names) => {
            let mut chosen = Vec::new();
            for (i, n) in names.iter().enumerate() {
                let field = format!("allocation.outputs[{i}]");
                let k = outputs
                    .iter()
                    .position(|o| o.name == n.value)
                    .ok_or_else(|| {
                        at(
                            line(n),
                            &field,
                            format!("`{}` is not among the study's outputs", n.value),
                        )
                    })?;
                if !limited(k) {
                    return Err(at(
                        line(n),
                        field,
                        format!("`{}` has no `limits`: a Cpk needs them", n.value),
                    ));
                }
                chosen.push(k);
            }
            chosen
        }
    };
    if chosen.is_empty() {
        return Err(at(
            line(spec),
            "allocation",
            "the target applies to outputs with limits, and the study gives no `limits`",
        ));
    }
    Ok(AllocationTarget {
        cpk,
        ppm,
        outputs: chosen,
        narrowest,
        widest,
    })
}

/// The value after `key:` on `line`, scaled by `ratio`, the unit kept as written
/// (`plus_minus: 0.05 mm` → `plus_minus: 0.06 mm`); `None` when the line does not hold it.
fn scale_on_line(line: &str, key: &str, ratio: f64) -> Option<String> {
    let mut from = 0;
    let start = loop {
        let k = from + line[from..].find(key)?;
        let before = line[..k].chars().next_back();
        let after = line[k + key.len()..].trim_start();
        if !before.is_some_and(|c| c.is_alphanumeric() || c == '_') && after.starts_with(':') {
            break k + key.len() + line[k + key.len()..].find(':')? + 1;
        }
        from = k + key.len();
    };
    let rest = &line[start..];
    let value_at = start + (rest.len() - rest.trim_start().len());
    let quoted = line[value_at..].starts_with(['"', '\'']);
    let number_at = value_at + usize::from(quoted);
    let tail = &line[number_at..];
    let len = tail
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || ((c == 'e' || c == 'E') && i > 0)
                || ((c == '-' || c == '+') && (i == 0 || tail[..i].ends_with(['e', 'E']))))
        })
        .map_or(tail.len(), |(i, _)| i);
    let old: f64 = tail[..len].parse().ok()?;
    // four significant digits, as a drawing writes a tolerance
    let new: f64 = format!("{:.3e}", old * ratio).parse().ok()?;
    Some(format!("{}{new}{}", &line[..number_at], &tail[len..]))
}

/// The study text with each toleranced parameter's band scaled by its ratio, renamed
/// `<name><suffix>` (its `output`, if written, too), so it runs beside the original.
pub fn retoleranced_text(
    text: &str,
    name: &str,
    ratios: &[f64],
    suffix: &str,
) -> Result<String, String> {
    let spec: super::schema::StudySpec = serde_saphyr::from_str(text).map_err(|e| e.to_string())?;
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut edit = |l: Option<u64>, key: &str, f: &dyn Fn(&str) -> Option<String>| {
        let k = l.ok_or(format!("`{key}` has no line"))? as usize - 1;
        lines[k] = f(&lines[k]).ok_or(format!("cannot rewrite `{key}` on line {}", k + 1))?;
        Ok::<(), String>(())
    };
    for (p, &r) in spec.parameters.iter().zip(ratios) {
        let Some(t) = &p.tolerance else { continue };
        if r == 1.0 {
            continue;
        }
        for (q, key) in [
            (&t.value.plus_minus, "plus_minus"),
            (&t.value.plus, "plus"),
            (&t.value.minus, "minus"),
        ] {
            if let Some(q) = q {
                edit(crate::scene::error::line(q), key, &|l| {
                    scale_on_line(l, key, r)
                })?;
            }
        }
    }
    let rename = |key: &'static str| {
        move |l: &str| {
            let at = l.find(key)? + key.len();
            let v = l[at..].trim_start_matches([':', ' ']);
            let (v, comment) = v.split_once(" #").unwrap_or((v, ""));
            let v = v.trim().trim_matches(['"', '\'']);
            let comment = if comment.is_empty() {
                String::new()
            } else {
                format!(" #{comment}")
            };
            Some(format!(
                "{}: \"{v}{suffix}\"{comment}",
                &l[..l.find(key)? + key.len()]
            ))
        }
    };
    if let Some(o) = &spec.output {
        edit(crate::scene::error::line(o), "output", &rename("output"))?;
    }
    match &spec.name {
        Some(n) => edit(crate::scene::error::line(n), "name", &rename("name"))?,
        None => lines.insert(0, format!("name: \"{name}{suffix}\"")),
    }
    Ok(lines.join("\n") + "\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drawing_reads_as_written() {
        let d = Drawing {
            nominal: 0.055,
            plus: 0.00005,
            minus: 0.00002,
            cp: Some(1.33),
        };
        let mm = DisplayUnit::auto(Dim::LENGTH, 0.055);
        assert_eq!(d.describe(&mm), "55 +0.05/−0.02 mm (normal, Cp 1.33)");
        let Distribution::Normal { mean, sd } = d.distribution() else {
            panic!()
        };
        assert!((mean - 0.055015).abs() < 1e-12);
        assert!((sd - 0.00007 / (6.0 * 1.33)).abs() < 1e-15);
        assert_eq!(Cost::default().at(2.0), 0.5);
    }

    #[test]
    fn a_band_is_rescaled_in_the_unit_it_is_written_in() {
        let l = "  - { path: a, tolerance: { nominal: 55 mm, plus_minus: 0.05 mm, cp: 1.33 } }";
        assert_eq!(
            scale_on_line(l, "plus_minus", 1.5).unwrap(),
            "  - { path: a, tolerance: { nominal: 55 mm, plus_minus: 0.075 mm, cp: 1.33 } }"
        );
        let l = "    tolerance: { nominal: 1, plus: \"2e-5 m\", minus: 1e-5 }";
        let once = scale_on_line(l, "plus", 2.0).unwrap();
        assert_eq!(
            once,
            "    tolerance: { nominal: 1, plus: \"0.00004 m\", minus: 1e-5 }"
        );
        assert_eq!(
            scale_on_line(&once, "minus", 2.0).unwrap(),
            "    tolerance: { nominal: 1, plus: \"0.00004 m\", minus: 0.00002 }"
        );
        assert!(scale_on_line("nominal: 3", "plus", 2.0).is_none());
    }
}
