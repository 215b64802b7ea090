//! Quantities in YAML: a plain number is SI; a string is a number followed by a unit
//! expression ("0.07 mm", "13 N", "2 ms", "9.81 m/s^2", "100 N/mm", "30 deg",
//! "1e-6 kg*m^2"). The unit's dimension is checked against the field's.

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;

/// Exponents of (length, mass, time). Angles are dimensionless (radians).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dim(pub i8, pub i8, pub i8);

impl Dim {
    pub const NONE: Dim = Dim(0, 0, 0);
    pub const LENGTH: Dim = Dim(1, 0, 0);
    pub const MASS: Dim = Dim(0, 1, 0);
    pub const TIME: Dim = Dim(0, 0, 1);
    pub const VELOCITY: Dim = Dim(1, 0, -1);
    pub const ACCELERATION: Dim = Dim(1, 0, -2);
    pub const ANGULAR_VELOCITY: Dim = Dim(0, 0, -1);
    pub const FORCE: Dim = Dim(1, 1, -2);
    pub const TORQUE: Dim = Dim(2, 1, -2);
    pub const STIFFNESS: Dim = Dim(0, 1, -2);
    pub const DAMPING: Dim = Dim(0, 1, -1);
    pub const ROTATIONAL_DAMPING: Dim = Dim(2, 1, -1);
    pub const INERTIA: Dim = Dim(2, 1, 0);
    pub const IMPULSE: Dim = Dim(1, 1, -1);
    pub const PRESSURE: Dim = Dim(-1, 1, -2);

    fn mul(self, o: Dim, exp: i8) -> Dim {
        Dim(self.0 + o.0 * exp, self.1 + o.1 * exp, self.2 + o.2 * exp)
    }

    /// The dimension of a unit label such as [`Dim::si_unit`] writes ("m", "N*m", "1");
    /// `None` for an empty or unknown label.
    pub fn of_unit(label: &str) -> Option<Dim> {
        match label.trim() {
            "" => None,
            "1" => Some(Dim::NONE),
            l => parse_quantity(&format!("1 {l}")).ok().and_then(|q| q.dim),
        }
    }

    /// The SI unit of the dimension, as written in output metadata ("m", "N", "1").
    pub fn si_unit(self) -> String {
        let named = [
            (Dim::NONE, "1"),
            (Dim::LENGTH, "m"),
            (Dim::MASS, "kg"),
            (Dim::TIME, "s"),
            (Dim::VELOCITY, "m/s"),
            (Dim::ACCELERATION, "m/s^2"),
            (Dim::ANGULAR_VELOCITY, "rad/s"),
            (Dim::FORCE, "N"),
            (Dim::TORQUE, "N*m"),
            (Dim::STIFFNESS, "N/m"),
            (Dim::INERTIA, "kg*m^2"),
            (Dim::IMPULSE, "N*s"),
            (Dim::PRESSURE, "Pa"),
        ];
        named
            .iter()
            .find(|(d, _)| *d == self)
            .map(|(_, n)| n.to_string())
            .unwrap_or_else(|| format!("m^{}*kg^{}*s^{}", self.0, self.1, self.2))
    }

    /// Human name of the dimension, for error messages.
    pub fn describe(self) -> String {
        let named = [
            (Dim::NONE, "dimensionless (or an angle)"),
            (Dim::LENGTH, "a length (e.g. mm)"),
            (Dim::MASS, "a mass (e.g. kg)"),
            (Dim::TIME, "a time (e.g. ms)"),
            (Dim::VELOCITY, "a velocity (e.g. m/s)"),
            (Dim::ACCELERATION, "an acceleration (e.g. m/s^2)"),
            (Dim::ANGULAR_VELOCITY, "an angular velocity (e.g. rad/s)"),
            (Dim::FORCE, "a force (e.g. N)"),
            (Dim::TORQUE, "a torque (e.g. N*m)"),
            (Dim::STIFFNESS, "a stiffness (e.g. N/m)"),
            (Dim::DAMPING, "a damping (e.g. N*s/m)"),
            (Dim::ROTATIONAL_DAMPING, "a rotational damping (e.g. N*m*s)"),
            (Dim::INERTIA, "an inertia (e.g. kg*m^2)"),
            (Dim::IMPULSE, "an impulse (e.g. N*s)"),
            (Dim::PRESSURE, "a pressure or a modulus (e.g. GPa)"),
        ];
        named
            .iter()
            .find(|(d, _)| *d == self)
            .map(|(_, n)| n.to_string())
            .unwrap_or_else(|| format!("m^{} kg^{} s^{}", self.0, self.1, self.2))
    }
}

/// A parsed quantity: its SI value and, when written with a unit, the unit's dimension.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantity {
    pub si: f64,
    pub dim: Option<Dim>,
}

impl Quantity {
    /// The SI value if the dimension matches `expected` (plain numbers always match).
    pub fn value(&self, expected: Dim) -> Result<f64, String> {
        match self.dim {
            Some(d) if d != expected => Err(format!(
                "has a unit of {} but {} is expected",
                d.describe(),
                expected.describe()
            )),
            _ => Ok(self.si),
        }
    }
}

/// (decimal exponent, other factor, dimension) of a unit: decimal prefixes are applied to
/// the number's text so that "0.07 mm" is exactly the double nearest 7e-5.
fn unit(name: &str) -> Option<(i32, f64, Dim)> {
    use std::f64::consts::PI;
    let l = Dim::LENGTH;
    let m = Dim::MASS;
    let t = Dim::TIME;
    Some(match name {
        "m" => (0, 1.0, l),
        "km" => (3, 1.0, l),
        "cm" => (-2, 1.0, l),
        "mm" => (-3, 1.0, l),
        "um" | "µm" | "μm" => (-6, 1.0, l),
        "nm" => (-9, 1.0, l),
        "kg" => (0, 1.0, m),
        "g" => (-3, 1.0, m),
        "mg" => (-6, 1.0, m),
        "s" => (0, 1.0, t),
        "ms" => (-3, 1.0, t),
        "us" | "µs" | "μs" => (-6, 1.0, t),
        "ns" => (-9, 1.0, t),
        "min" => (0, 60.0, t),
        "N" => (0, 1.0, Dim::FORCE),
        "kN" => (3, 1.0, Dim::FORCE),
        "mN" => (-3, 1.0, Dim::FORCE),
        "J" => (0, 1.0, Dim::TORQUE),
        "Pa" => (0, 1.0, Dim::PRESSURE),
        "kPa" => (3, 1.0, Dim::PRESSURE),
        "MPa" => (6, 1.0, Dim::PRESSURE),
        "GPa" => (9, 1.0, Dim::PRESSURE),
        "rad" => (0, 1.0, Dim::NONE),
        "mrad" => (-3, 1.0, Dim::NONE),
        "deg" | "°" => (0, PI / 180.0, Dim::NONE),
        "rpm" => (0, 2.0 * PI / 60.0, Dim::ANGULAR_VELOCITY),
        "Hz" => (0, 1.0, Dim::ANGULAR_VELOCITY),
        _ => return None,
    })
}

/// Parses "number unit-expression"; the unit expression is factors joined by `*`, `·` or
/// spaces, with at most one `/` (everything after it is in the denominator) and `^n`
/// exponents.
pub fn parse_quantity(text: &str) -> Result<Quantity, String> {
    let s = text.trim();
    let split = s
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || c == '+'
                || c == '-'
                || ((c == 'e' || c == 'E')
                    && i > 0
                    && s[i + 1..]
                        .starts_with(|d: char| d.is_ascii_digit() || d == '-' || d == '+')))
        })
        .map_or(s.len(), |(i, _)| i);
    let (num, rest) = s.split_at(split);
    let value: f64 = num.parse().map_err(|_| {
        format!("`{text}` is not a number with an optional unit (e.g. \"0.07 mm\")")
    })?;
    let rest = rest.trim();
    if rest.is_empty() {
        return Ok(Quantity {
            si: value,
            dim: None,
        });
    }
    let (numer, denom) = match rest.split_once('/') {
        Some((a, b)) => (a, Some(b)),
        None => (rest, None),
    };
    let mut exp10 = 0i32;
    let mut factor = 1.0;
    let mut dim = Dim::NONE;
    for (part, sign) in [(Some(numer), 1i8), (denom, -1i8)] {
        let Some(part) = part else { continue };
        for tok in part.split(['*', '·', ' ']).filter(|t| !t.is_empty()) {
            let (name, exp) = match tok.split_once('^') {
                Some((n, e)) => (
                    n,
                    e.parse::<i8>()
                        .map_err(|_| format!("bad exponent in unit `{tok}` of `{text}`"))?,
                ),
                None => (tok, 1),
            };
            let (e10, f, d) = unit(name).ok_or_else(|| {
                format!("unknown unit `{name}` in `{text}` (known: m km cm mm um nm kg g mg s ms us min N kN mN J rad mrad deg rpm Hz, combined with * / ^)")
            })?;
            exp10 += e10 * i32::from(exp * sign);
            factor *= f.powi(i32::from(exp * sign));
            dim = dim.mul(d, exp * sign);
        }
    }
    let (mantissa, e0) = match num.split_once(['e', 'E']) {
        Some((m, e)) => (m, e.parse::<i32>().unwrap_or(0)),
        None => (num, 0),
    };
    let scaled: f64 = format!("{mantissa}e{}", e0 + exp10)
        .parse()
        .unwrap_or(value * 10f64.powi(exp10));
    Ok(Quantity {
        si: scaled * factor,
        dim: Some(dim),
    })
}

/// The unit a value is shown in ("mm", "µs", "N*mm"): its label and the factor that turns
/// an SI value into it. Values are stored in SI; only what is printed or drawn is scaled.
#[derive(Clone, Debug, PartialEq)]
pub struct DisplayUnit {
    pub label: String,
    /// Display value = SI value × `per_si`.
    pub per_si: f64,
}

impl DisplayUnit {
    /// The SI unit of `dim` itself ("m", "N"; empty for a pure number).
    pub fn si(dim: Dim) -> DisplayUnit {
        let label = dim.si_unit();
        DisplayUnit {
            label: if label == "1" { String::new() } else { label },
            per_si: 1.0,
        }
    }

    /// A unit written by the user (`unit: mm` on a probe), checked against the value's
    /// dimension.
    pub fn parse(label: &str, dim: Dim) -> Result<DisplayUnit, String> {
        let q = parse_quantity(&format!("1 {label}"))?;
        let d = q.dim.unwrap_or(Dim::NONE);
        if d != dim {
            return Err(format!(
                "`{label}` is {} but the value is {}",
                d.describe(),
                dim.describe()
            ));
        }
        Ok(DisplayUnit {
            label: label.trim().to_string(),
            per_si: 1.0 / q.si,
        })
    }

    /// A readable unit for values of dimension `dim` whose largest magnitude is `big`:
    /// lengths in m, mm or µm and times in s, ms or µs (the first whose value is at least
    /// 0.1), anything else in SI.
    pub fn auto(dim: Dim, big: f64) -> DisplayUnit {
        let options: &[(f64, &str)] = match dim {
            Dim::LENGTH => &[(1.0, "m"), (1e3, "mm"), (1e6, "µm")],
            Dim::TIME => &[(1.0, "s"), (1e3, "ms"), (1e6, "µs")],
            Dim::PRESSURE => &[(1e-9, "GPa"), (1e-6, "MPa"), (1e-3, "kPa"), (1.0, "Pa")],
            _ => return DisplayUnit::si(dim),
        };
        let (per_si, label) = options
            .iter()
            .find(|(f, _)| big * f >= 0.1)
            .or(options.last())
            .copied()
            .expect("options are not empty");
        DisplayUnit {
            label: label.to_string(),
            per_si,
        }
    }

    /// A readable unit ([`DisplayUnit::auto`]) for values labelled with the SI unit
    /// `si_unit`; a label it does not know is kept as it is.
    pub fn for_values(si_unit: &str, values: &[f64]) -> DisplayUnit {
        let big = values
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        match Dim::of_unit(si_unit) {
            Some(dim) => DisplayUnit::auto(dim, big),
            None => DisplayUnit {
                label: si_unit.to_string(),
                per_si: 1.0,
            },
        }
    }

    /// "name [unit]", for an axis or a column heading.
    pub fn heading(&self, name: &str) -> String {
        if self.label.is_empty() {
            name.to_string()
        } else {
            format!("{name} [{}]", self.label)
        }
    }

    /// The value `si` in this unit.
    pub fn of(&self, si: f64) -> f64 {
        si * self.per_si
    }
}

impl<'de> Deserialize<'de> for Quantity {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Quantity;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number (SI) or a string with a unit such as \"0.07 mm\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Quantity, E> {
                Ok(Quantity { si: v, dim: None })
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Quantity, E> {
                Ok(Quantity {
                    si: v as f64,
                    dim: None,
                })
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Quantity, E> {
                Ok(Quantity {
                    si: v as f64,
                    dim: None,
                })
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Quantity, E> {
                parse_quantity(v).map_err(E::custom)
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_units_to_si() {
        let q = |s: &str| parse_quantity(s).unwrap();
        assert_eq!(q("0.07 mm").si, 0.07e-3);
        assert_eq!(q("0.07 mm").dim, Some(Dim::LENGTH));
        assert_eq!(q("2 ms").si, 2e-3);
        assert_eq!(q("13 N").dim, Some(Dim::FORCE));
        assert!((q("9.81 m/s^2").si - 9.81).abs() < 1e-15);
        assert_eq!(q("9.81 m/s^2").dim, Some(Dim::ACCELERATION));
        assert!((q("100 N/mm").si - 1e5).abs() < 1e-9);
        assert_eq!(q("100 N/mm").dim, Some(Dim::STIFFNESS));
        assert!((q("180 deg").si - std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(q("1e-6 kg*m^2").dim, Some(Dim::INERTIA));
        assert_eq!(q("5 N m").dim, Some(Dim::TORQUE));
        assert_eq!(q("-1.5e-3").si, -1.5e-3);
        assert_eq!(q("1.5e-3 mm").si, 1.5e-6);
        assert_eq!(q("2 N*s/m").dim, Some(Dim::DAMPING));
        assert!((q("60 rpm").si - 2.0 * std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn display_units_scale_si_values() {
        let mm = DisplayUnit::parse("mm", Dim::LENGTH).unwrap();
        assert_eq!(mm.of(0.0107), 10.7);
        let nmm = DisplayUnit::parse("N*mm", Dim::TORQUE).unwrap();
        assert!((nmm.of(0.04) - 40.0).abs() < 1e-12);
        let deg = DisplayUnit::parse("deg", Dim::NONE).unwrap();
        assert!((deg.of(std::f64::consts::PI) - 180.0).abs() < 1e-12);
        let e = DisplayUnit::parse("ms", Dim::LENGTH).unwrap_err();
        assert!(e.contains("a time") && e.contains("a length"), "{e}");
        assert_eq!(DisplayUnit::auto(Dim::LENGTH, 0.0107).label, "mm");
        assert_eq!(DisplayUnit::auto(Dim::LENGTH, 5e-7).label, "µm");
        assert_eq!(DisplayUnit::auto(Dim::TIME, 0.25).label, "s");
        assert_eq!(DisplayUnit::auto(Dim::FORCE, 1e-3).label, "N");
        assert_eq!(DisplayUnit::auto(Dim::PRESSURE, 2.1e10).label, "GPa");
        assert_eq!(DisplayUnit::auto(Dim::PRESSURE, 2e7).label, "MPa");
        let gpa = DisplayUnit::parse("GPa", Dim::PRESSURE).unwrap();
        assert!((gpa.of(2.1e11) - 210.0).abs() < 1e-9);
        assert_eq!(
            parse_quantity("210 GPa").unwrap().value(Dim::PRESSURE),
            Ok(2.1e11)
        );
        assert_eq!(DisplayUnit::for_values("s", &[4.7e-3]).label, "ms");
        assert_eq!(DisplayUnit::for_values("1", &[3.0]).heading("y"), "y");
        assert_eq!(DisplayUnit::for_values("m", &[0.69]).heading("x"), "x [m]");
    }

    #[test]
    fn rejects_bad_units_and_wrong_dimensions() {
        assert!(parse_quantity("5 furlongs")
            .unwrap_err()
            .contains("unknown unit `furlongs`"));
        assert!(parse_quantity("abc").is_err());
        let e = parse_quantity("5 ms")
            .unwrap()
            .value(Dim::LENGTH)
            .unwrap_err();
        assert!(e.contains("a time") && e.contains("a length"), "{e}");
        assert_eq!(parse_quantity("5").unwrap().value(Dim::LENGTH), Ok(5.0));
    }
}
