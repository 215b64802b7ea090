//! Parameter paths: every number of a scene document, addressed the way the document is
//! written. List entries go by their `name` (by index where they have none), vector
//! components by x, y, z (a quaternion's by w, x, y, z, longer lists and table cells by
//! index, a profile point's by u, v): `joints.D.anchor.x`, `forces.0.spring.stiffness`,
//! `bodies.hook.shape.box.size.y`, `integrator.h`, `settle.until`.
//!
//! A study (or `--set`) writes its values into the parsed document, which is then built
//! and validated like a file: a parameter needs no code of its own, and a value the
//! scene refuses fails with the message and line of the field it was written to.
//!
//! Each part of the schema lists its numbers here with their dimension, in one
//! [`Node::visit`]; two visitors walk them: one lists every path, the other finds one.

use super::build::RECORD_EVERY;
use super::clearance::{AXIAL_PLAY, RIM_POINTS};
use super::compliance::SLIP_SPEED;
use super::integrator::apply_integrator;
use super::schema::*;
use crate::input::units::{Dim, Quantity};
use crate::integrator::IntegrationParameters;
use serde_saphyr::{Location, Spanned};

/// A parameter path of a scene with the dimension of its value, its value in the document
/// (`None` where the document leaves it out), and what applies where it is left out.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterPath {
    pub path: String,
    pub dim: Dim,
    pub value: Option<f64>,
    pub default: Fallback,
}

/// What a number the document leaves out stands for: a value (SI), or the rule that
/// derives it from the rest of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fallback {
    Value(f64),
    Rule(&'static str),
}

impl std::fmt::Display for Fallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fallback::Value(v) => write!(f, "{v}"),
            Fallback::Rule(r) => f.write_str(r),
        }
    }
}

/// The value of a number the scene needs (`paths` lists it where it is missing, before the
/// scene is refused).
const REQUIRED: Fallback = Fallback::Rule("required");
const NONE: Fallback = Fallback::Value(0.0);
const DRIVE_TABLE: Fallback = Fallback::Rule("drive.position_table");

/// Something the walk reaches: a part of the document that holds numbers.
pub(super) trait Node {
    fn visit(&mut self, v: &mut dyn Visitor);
}

/// What walks the document. The parts call it for each number they hold, and for the
/// parts below them.
pub(super) trait Visitor {
    /// An optional number, `default` where it is left out.
    fn scalar(&mut self, name: &str, q: &mut Option<Q>, dim: Dim, default: Fallback);
    /// A required number.
    fn required(&mut self, name: &str, q: &mut Q, dim: Dim);
    /// An optional vector, `default` where it is left out (`None`: none makes sense).
    fn vector(&mut self, name: &str, v: &mut Option<Vector>, dim: Dim, default: Option<&[f64]>);
    /// A required vector.
    fn required_vector(&mut self, name: &str, v: &mut Vector, dim: Dim);
    /// A table of rows whose columns have the dimensions `dims`.
    fn table(&mut self, name: &str, t: &mut Option<Spanned<Vec<Vec<Quantity>>>>, dims: &[Dim]);
    /// A part below this one.
    fn node(&mut self, name: &str, node: &mut dyn Node);
    /// A list of parts, each by its name (or index where it has none).
    fn list(&mut self, name: &str, items: Vec<(String, &mut dyn Node)>);
    /// A field this part does not have in its present form, and why (a clearance on an
    /// ideal joint): a path to it gets the reason instead of "unknown".
    fn absent(&mut self, name: &str, why: &str);
}

/// A quantity written by a parameter: SI, no unit (the path's dimension is known).
pub fn written(value: f64) -> Q {
    Spanned::new(
        Quantity {
            si: value,
            dim: None,
        },
        Location::UNKNOWN,
        Location::UNKNOWN,
    )
}

/// The names of a vector's components: u, v for two (a point of a profile's plane), x, y, z
/// for three, w, x, y, z for four, else the indices.
fn component_names(len: usize) -> Vec<String> {
    match len {
        2 => ["u", "v"].map(String::from).to_vec(),
        3 => ["x", "y", "z"].map(String::from).to_vec(),
        4 => ["w", "x", "y", "z"].map(String::from).to_vec(),
        n => (0..n).map(|i| i.to_string()).collect(),
    }
}

/// Collects every path.
struct Lister {
    prefix: Vec<String>,
    out: Vec<ParameterPath>,
}

impl Lister {
    fn path(&self, name: &str) -> String {
        let mut p = self.prefix.join(".");
        if !p.is_empty() {
            p.push('.');
        }
        p + name
    }

    fn push(&mut self, path: String, dim: Dim, value: Option<f64>, default: Fallback) {
        self.out.push(ParameterPath {
            path,
            dim,
            value,
            default,
        });
    }
}

impl Visitor for Lister {
    fn scalar(&mut self, name: &str, q: &mut Option<Q>, dim: Dim, default: Fallback) {
        let value = q.as_ref().map(|q| q.value.si);
        self.push(self.path(name), dim, value, default);
    }

    fn required(&mut self, name: &str, q: &mut Q, dim: Dim) {
        self.push(self.path(name), dim, Some(q.value.si), REQUIRED);
    }

    fn vector(&mut self, name: &str, v: &mut Option<Vector>, dim: Dim, default: Option<&[f64]>) {
        match v {
            Some(v) => self.required_vector(name, v, dim),
            None => {
                if let Some(d) = default {
                    for (c, &x) in component_names(d.len()).iter().zip(d) {
                        let path = self.path(&format!("{name}.{c}"));
                        self.push(path, dim, None, Fallback::Value(x));
                    }
                }
            }
        }
    }

    fn required_vector(&mut self, name: &str, v: &mut Vector, dim: Dim) {
        for (c, q) in component_names(v.value.len()).iter().zip(&v.value) {
            let path = self.path(&format!("{name}.{c}"));
            self.push(path, dim, Some(q.si), REQUIRED);
        }
    }

    fn table(&mut self, name: &str, t: &mut Option<Spanned<Vec<Vec<Quantity>>>>, dims: &[Dim]) {
        let Some(t) = t else { return };
        for (r, row) in t.value.iter().enumerate() {
            for (c, q) in row.iter().enumerate() {
                if let Some(&dim) = dims.get(c) {
                    let path = self.path(&format!("{name}.{r}.{c}"));
                    self.push(path, dim, Some(q.si), REQUIRED);
                }
            }
        }
    }

    fn node(&mut self, name: &str, node: &mut dyn Node) {
        self.prefix.push(name.to_string());
        node.visit(self);
        self.prefix.pop();
    }

    fn list(&mut self, name: &str, items: Vec<(String, &mut dyn Node)>) {
        self.prefix.push(name.to_string());
        for (key, node) in items {
            self.node(&key, node);
        }
        self.prefix.pop();
    }

    fn absent(&mut self, _name: &str, _why: &str) {}
}

/// Finds one path and, when given a value, writes it there.
struct Finder<'p> {
    /// The path's segments.
    target: &'p [&'p str],
    /// How many segments the walk has matched.
    depth: usize,
    value: Option<f64>,
    /// Whether the value is written with the path's unit (checked by the builder) rather
    /// than as a plain SI number.
    with_unit: bool,
    /// The dimension of the value at the path, once found; or why the path names no
    /// number although it names a part of the document.
    found: Option<Result<Dim, String>>,
}

impl Finder<'_> {
    /// The segments below `name`, if `name` is the next segment of the target.
    fn below(&self, name: &str) -> Option<&[&str]> {
        (self.found.is_none() && self.target.get(self.depth) == Some(&name))
            .then(|| &self.target[self.depth + 1..])
    }

    fn found(&mut self, r: Result<Dim, String>) {
        self.found = Some(r);
    }

    fn set(&self, q: &mut Quantity, dim: Dim) {
        if let Some(v) = self.value {
            *q = Quantity {
                si: v,
                dim: self.with_unit.then_some(dim),
            };
        }
    }

    /// Component `c` of a vector of `len` components, by name.
    fn component(c: &str, len: usize) -> Option<usize> {
        component_names(len).iter().position(|n| n == c)
    }
}

impl Visitor for Finder<'_> {
    fn scalar(&mut self, name: &str, q: &mut Option<Q>, dim: Dim, _: Fallback) {
        if self.below(name) == Some(&[]) {
            if self.value.is_some() {
                let mut w = written(0.0);
                self.set(&mut w.value, dim);
                *q = Some(w);
            }
            self.found(Ok(dim));
        }
    }

    fn required(&mut self, name: &str, q: &mut Q, dim: Dim) {
        if self.below(name) == Some(&[]) {
            self.set(&mut q.value, dim);
            self.found(Ok(dim));
        }
    }

    fn vector(&mut self, name: &str, v: &mut Option<Vector>, dim: Dim, default: Option<&[f64]>) {
        if self.below(name).is_none() {
            return;
        }
        if v.is_none() {
            match default {
                Some(d) => {
                    // written with its default, then set like a written vector
                    let mut filled = Spanned::new(
                        d.iter().map(|&si| Quantity { si, dim: None }).collect(),
                        Location::UNKNOWN,
                        Location::UNKNOWN,
                    );
                    self.required_vector(name, &mut filled, dim);
                    if self.value.is_some() && matches!(self.found, Some(Ok(_))) {
                        *v = Some(filled);
                    }
                }
                None => self.found(Err(format!(
                    "the scene does not give `{}`; write it in the scene to vary it",
                    self.target[..=self.depth].join(".")
                ))),
            }
            return;
        }
        self.required_vector(name, v.as_mut().expect("given"), dim);
    }

    fn required_vector(&mut self, name: &str, v: &mut Vector, dim: Dim) {
        let Some(rest) = self.below(name) else { return };
        let len = v.value.len();
        match rest {
            [c] => match Finder::component(c, len) {
                Some(k) => {
                    self.set(&mut v.value[k], dim);
                    self.found(Ok(dim));
                }
                None => self.found(Err(format!(
                    "`{name}` has the components {}",
                    component_names(len).join(", ")
                ))),
            },
            _ => self.found(Err(format!(
                "name a component of `{name}`: {}",
                component_names(len).join(", ")
            ))),
        }
    }

    fn table(&mut self, name: &str, t: &mut Option<Spanned<Vec<Vec<Quantity>>>>, dims: &[Dim]) {
        let Some(rest) = self.below(name) else { return };
        let Some(t) = t else { return };
        let cell = match rest {
            [r, c] => r.parse::<usize>().ok().zip(c.parse::<usize>().ok()),
            _ => None,
        };
        match cell {
            Some((r, c)) if r < t.value.len() && c < t.value[r].len() && c < dims.len() => {
                self.set(&mut t.value[r][c], dims[c]);
                self.found(Ok(dims[c]));
            }
            _ => self.found(Err(format!(
                "`{name}` is a table: name a row and a column, `{name}.ROW.COLUMN`, within its {} rows",
                t.value.len()
            ))),
        }
    }

    fn node(&mut self, name: &str, node: &mut dyn Node) {
        if self.below(name).is_some() {
            self.depth += 1;
            node.visit(self);
            self.depth -= 1;
        }
    }

    fn list(&mut self, name: &str, items: Vec<(String, &mut dyn Node)>) {
        if self.below(name).is_none() {
            return;
        }
        self.depth += 1;
        for (key, node) in items {
            self.node(&key, node);
        }
        self.depth -= 1;
    }

    fn absent(&mut self, name: &str, why: &str) {
        if self.below(name).is_some() {
            self.found(Err(why.to_string()));
        }
    }
}

/// The key of list entry `i`: its name, or its index where it has none.
fn key(name: Option<&Name>, i: usize) -> String {
    name.map_or(i.to_string(), |n| n.value.clone())
}

impl Node for SceneSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.required("duration", &mut self.duration, Dim::TIME);
        v.vector(
            "gravity",
            &mut self.gravity,
            Dim::ACCELERATION,
            Some(&[0.0, 0.0, -9.81]),
        );
        v.node("integrator", &mut self.integrator);
        v.list(
            "bodies",
            self.bodies
                .iter_mut()
                .map(|b| (b.name.value.clone(), b as &mut dyn Node))
                .collect(),
        );
        v.list(
            "contacts",
            self.contacts
                .iter_mut()
                .enumerate()
                .map(|(i, c)| {
                    let k = c.name.clone().unwrap_or_else(|| i.to_string());
                    (k, c as &mut dyn Node)
                })
                .collect(),
        );
        v.list(
            "forces",
            self.forces
                .iter_mut()
                .enumerate()
                .map(|(i, f)| (key(f.name.as_ref(), i), f as &mut dyn Node))
                .collect(),
        );
        v.list(
            "joints",
            self.joints
                .iter_mut()
                .map(|j| (j.name.value.clone(), j as &mut dyn Node))
                .collect(),
        );
        v.node("record", &mut self.record);
        if let Some(s) = &mut self.settle {
            v.node("settle", &mut s.value);
        }
        if let Some(r) = &mut self.refine {
            v.node("refine", &mut r.value);
        }
    }
}

impl Node for IntegratorSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        // what the block leaves out is its preset's value, or the engine's
        let mut p = IntegrationParameters::default();
        let _ = apply_integrator(self, &mut p, "integrator");
        let d = Fallback::Value;
        v.scalar("h", &mut self.h, Dim::TIME, d(p.h));
        v.scalar("theta", &mut self.theta, Dim::NONE, d(p.theta));
        v.scalar("gamma", &mut self.gamma, Dim::NONE, d(p.gamma));
        let margin = d(p.activation_margin);
        v.scalar(
            "activation_margin",
            &mut self.activation_margin,
            Dim::LENGTH,
            margin,
        );
        for (name, t, (tolerance, iterations)) in [
            (
                "solver",
                &mut self.solver,
                (p.solver.tolerance, p.solver.max_sweeps),
            ),
            (
                "newton",
                &mut self.newton,
                (p.newton_tolerance, p.newton_max_iterations),
            ),
            (
                "projection",
                &mut self.projection,
                (p.projection_tolerance, p.projection_max_iterations),
            ),
        ] {
            let t = t.get_or_insert_with(ToleranceSpec::default);
            v.node(
                name,
                &mut With(|v: &mut dyn Visitor| {
                    v.scalar("tolerance", &mut t.tolerance, Dim::NONE, d(tolerance));
                    let most = d(iterations as f64);
                    v.scalar("max_iterations", &mut t.max_iterations, Dim::NONE, most);
                }),
            );
        }
        // only a block that is there: an empty one would switch the control on
        if let (Some(StepControlSpec::On(b)), Some(c)) = (&mut self.step_control, &p.step_control) {
            v.node(
                "step_control",
                &mut With(|v: &mut dyn Visitor| {
                    v.scalar("tolerance", &mut b.tolerance, Dim::NONE, d(c.tolerance));
                    v.scalar("h_max", &mut b.h_max, Dim::TIME, d(c.h_max));
                    v.scalar("h_min", &mut b.h_min, Dim::TIME, d(c.h_min));
                    v.scalar("length", &mut b.length, Dim::LENGTH, d(c.length));
                    v.scalar("speed", &mut b.speed, Dim::VELOCITY, d(c.speed));
                }),
            );
        }
    }
}

impl Node for RecordSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        let every = Fallback::Value(RECORD_EVERY as f64);
        v.scalar("every", &mut self.every, Dim::NONE, every);
    }
}

impl Node for SettleSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.required("until", &mut self.until, Dim::TIME);
        v.scalar("damping", &mut self.damping, Dim::ANGULAR_VELOCITY, NONE);
        let h = Fallback::Rule("integrator.h");
        v.scalar("h", &mut self.h, Dim::TIME, h);
        let tolerance = Fallback::Rule("integrator.solver.tolerance");
        v.scalar("tolerance", &mut self.tolerance, Dim::NONE, tolerance);
    }
}

impl Node for RefineSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.required("for", &mut self.duration, Dim::TIME);
        v.required("h", &mut self.h, Dim::TIME);
        let h = Fallback::Rule("integrator.h");
        v.scalar("approach", &mut self.approach, Dim::TIME, h);
    }
}

const ZERO: [f64; 3] = [0.0; 3];
const Z_AXIS: [f64; 3] = [0.0, 0.0, 1.0];

/// A part given by a closure over its fields: the fields of an enum variant, below its
/// kind's name (`shape.box.size.x`).
struct With<F: FnMut(&mut dyn Visitor)>(F);

impl<F: FnMut(&mut dyn Visitor)> Node for With<F> {
    fn visit(&mut self, v: &mut dyn Visitor) {
        (self.0)(v)
    }
}

impl Node for BodySpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.scalar("mass", &mut self.mass, Dim::MASS, REQUIRED);
        v.vector("inertia", &mut self.inertia, Dim::INERTIA, None);
        if let Some(s) = &mut self.shape {
            v.node("shape", &mut s.value);
        }
        v.vector("position", &mut self.position, Dim::LENGTH, Some(&ZERO));
        if let Some(o) = &mut self.orientation {
            v.node("orientation", &mut o.value);
        }
        v.vector("velocity", &mut self.velocity, Dim::VELOCITY, Some(&ZERO));
        v.vector(
            "angular_velocity",
            &mut self.angular_velocity,
            Dim::ANGULAR_VELOCITY,
            Some(&ZERO),
        );
    }
}

impl Node for ShapeSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        match self {
            ShapeSpec::Box { size } => v.node(
                "box",
                &mut With(|v: &mut dyn Visitor| v.required_vector("size", size, Dim::LENGTH)),
            ),
            ShapeSpec::Cylinder { radius, length } => v.node(
                "cylinder",
                &mut With(|v: &mut dyn Visitor| {
                    v.required("radius", radius, Dim::LENGTH);
                    v.required("length", length, Dim::LENGTH);
                }),
            ),
            ShapeSpec::Sphere { radius } => v.node(
                "sphere",
                &mut With(|v: &mut dyn Visitor| v.required("radius", radius, Dim::LENGTH)),
            ),
        }
    }
}

impl Node for OrientationSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.vector("axis", &mut self.axis, Dim::NONE, None);
        let angle = match self.axis {
            Some(_) => REQUIRED,
            None => Fallback::Rule("unused: goes with axis"),
        };
        v.scalar("angle", &mut self.angle, Dim::NONE, angle);
        v.vector("quaternion", &mut self.quaternion, Dim::NONE, None);
        v.vector(
            "rotation_vector",
            &mut self.rotation_vector,
            Dim::NONE,
            None,
        );
    }
}

impl Node for ContactSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.node("shape", &mut self.shape.value);
        v.node("against_shape", &mut self.against_shape.value);
        v.scalar("mu", &mut self.mu, Dim::NONE, NONE);
        v.scalar("e", &mut self.e, Dim::NONE, NONE);
        if let Some(c) = &mut self.compliance {
            v.node("compliance", &mut c.value);
        }
    }
}

impl Node for ComplianceSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        for (name, m) in [
            ("material", &mut self.material),
            ("against_material", &mut self.against_material),
        ] {
            if let Some(m) = m {
                let m = &mut m.value;
                v.node(
                    name,
                    &mut With(|v: &mut dyn Visitor| {
                        v.required("E", &mut m.youngs_modulus, Dim::PRESSURE);
                        v.required("nu", &mut m.nu, Dim::NONE);
                    }),
                );
            }
        }
        let hertz = Fallback::Rule("Hertz's, from `material`");
        v.scalar("stiffness", &mut self.stiffness, Dim::NONE, hertz);
        v.scalar(
            "exponent",
            &mut self.exponent,
            Dim::NONE,
            Fallback::Value(1.5),
        );
        let slip = Fallback::Value(SLIP_SPEED);
        v.scalar("slip_speed", &mut self.slip_speed, Dim::VELOCITY, slip);
    }
}

impl Node for PrimitiveSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        const L: Dim = Dim::LENGTH;
        // the key of a cylinder, cone or capsule, which share their fields
        let round = match self {
            PrimitiveSpec::Cylinder { .. } => "cylinder",
            PrimitiveSpec::Cone { .. } => "cone",
            _ => "capsule",
        };
        match self {
            PrimitiveSpec::Sphere { radius, center } => v.node(
                "sphere",
                &mut With(|v: &mut dyn Visitor| {
                    v.required("radius", radius, L);
                    v.vector("center", center, L, Some(&ZERO));
                }),
            ),
            PrimitiveSpec::Plane { point, normal } => v.node(
                "plane",
                &mut With(|v: &mut dyn Visitor| {
                    v.vector("point", point, L, Some(&ZERO));
                    v.required_vector("normal", normal, Dim::NONE);
                }),
            ),
            PrimitiveSpec::Box {
                size,
                center,
                orientation,
            } => visit_box(v, size, center, orientation),
            PrimitiveSpec::Cylinder {
                radius,
                length,
                axis,
                center,
            }
            | PrimitiveSpec::Cone {
                radius,
                length,
                axis,
                center,
            }
            | PrimitiveSpec::Capsule {
                radius,
                length,
                axis,
                center,
            } => v.node(
                round,
                &mut With(|v: &mut dyn Visitor| {
                    v.required("radius", radius, L);
                    v.required("length", length, L);
                    v.vector("axis", axis, Dim::NONE, Some(&Z_AXIS));
                    v.vector("center", center, L, Some(&ZERO));
                }),
            ),
            PrimitiveSpec::Point { position } => v.node(
                "point",
                &mut With(|v: &mut dyn Visitor| v.required_vector("position", position, L)),
            ),
            PrimitiveSpec::Profile(p) => v.node("profile", p),
            PrimitiveSpec::Convex {
                vertices,
                file,
                scale,
                rounding,
            } => visit_convex(v, vertices, file.is_some(), scale, rounding),
            PrimitiveSpec::Mesh { scale, .. } => v.node(
                "mesh",
                &mut With(|v: &mut dyn Visitor| v.required("scale", scale, L)),
            ),
        }
    }
}

impl Node for ProfileSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        const L: Dim = Dim::LENGTH;
        v.scalar("offset", &mut self.offset, L, NONE);
        v.required("thickness", &mut self.thickness, L);
        v.vector("start", &mut self.start, L, None);
        v.list(
            "path",
            self.path
                .value
                .iter_mut()
                .enumerate()
                .map(|(i, piece)| (i.to_string(), &mut piece.value as &mut dyn Node))
                .collect(),
        );
    }
}

impl Node for PieceSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        const L: Dim = Dim::LENGTH;
        match self {
            PieceSpec::Line(to) => v.required_vector("line", to, L),
            PieceSpec::Arc { to, center, .. } => v.node(
                "arc",
                &mut With(|v: &mut dyn Visitor| {
                    v.required_vector("to", to, L);
                    v.required_vector("center", center, L);
                }),
            ),
            PieceSpec::Circle { center, radius } => v.node(
                "circle",
                &mut With(|v: &mut dyn Visitor| {
                    v.required_vector("center", center, L);
                    v.required("radius", radius, L);
                }),
            ),
        }
    }
}

impl Node for ForceSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        if let Some(s) = &mut self.spring {
            v.node("spring", &mut s.value);
        }
        if let Some(s) = &mut self.torsional_spring {
            v.node("torsional_spring", &mut s.value);
        }
        if let Some(l) = &mut self.load {
            v.node("load", &mut l.value);
        }
    }
}

impl Node for SpringSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.vector("point_a", &mut self.point_a, Dim::LENGTH, Some(&ZERO));
        v.vector("point_b", &mut self.point_b, Dim::LENGTH, Some(&ZERO));
        v.required("stiffness", &mut self.stiffness, Dim::STIFFNESS);
        v.scalar("damping", &mut self.damping, Dim::DAMPING, NONE);
        let written = Fallback::Rule("the written length");
        v.scalar("rest_length", &mut self.rest_length, Dim::LENGTH, written);
        v.scalar("preload", &mut self.preload, Dim::FORCE, NONE);
        v.scalar("ramp", &mut self.ramp, Dim::TIME, NONE);
    }
}

impl Node for TorsionalSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.required_vector("axis", &mut self.axis, Dim::NONE);
        v.required("stiffness", &mut self.stiffness, Dim::TORQUE);
        v.scalar("damping", &mut self.damping, Dim::ROTATIONAL_DAMPING, NONE);
        v.scalar("preload", &mut self.preload, Dim::TORQUE, NONE);
        // two ways to give the rest angle: the one left out is not used
        let (rest, free) = match self.free_angle {
            Some(_) => (Fallback::Rule("unused: free_angle applies"), NONE),
            None => (NONE, Fallback::Rule("unused: rest_angle applies")),
        };
        v.scalar("rest_angle", &mut self.rest_angle, Dim::NONE, rest);
        v.scalar("free_angle", &mut self.free_angle, Dim::NONE, free);
        v.scalar("ramp", &mut self.ramp, Dim::TIME, NONE);
    }
}

impl Node for LoadSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        v.vector("point", &mut self.point, Dim::LENGTH, Some(&ZERO));
        v.vector("force", &mut self.force, Dim::FORCE, None);
        v.table(
            "force_table",
            &mut self.force_table,
            &[Dim::TIME, Dim::FORCE, Dim::FORCE, Dim::FORCE],
        );
        v.vector("torque", &mut self.torque, Dim::TORQUE, None);
        v.table(
            "torque_table",
            &mut self.torque_table,
            &[Dim::TIME, Dim::TORQUE, Dim::TORQUE, Dim::TORQUE],
        );
    }
}

impl Node for JointSpec {
    fn visit(&mut self, v: &mut dyn Visitor) {
        const L: Dim = Dim::LENGTH;
        // the joint coordinate: an angle for revolute joints, a length for prismatic ones
        let prismatic = self.kind.value == "prismatic";
        let (coordinate, rate, effort) = if prismatic {
            (L, Dim::VELOCITY, Dim::FORCE)
        } else {
            (Dim::NONE, Dim::ANGULAR_VELOCITY, Dim::TORQUE)
        };
        v.vector("anchor", &mut self.anchor, L, None);
        v.vector("axis", &mut self.axis, Dim::NONE, None);
        v.vector("anchor_a", &mut self.anchor_a, L, None);
        v.vector("anchor_b", &mut self.anchor_b, L, None);
        v.vector("axis_a", &mut self.axis_a, Dim::NONE, None);
        v.vector("axis_b", &mut self.axis_b, Dim::NONE, None);
        if let Some(d) = &mut self.drive {
            visit_drive(v, &mut d.value, (coordinate, rate, effort));
        }
        if let Some(l) = &mut self.limits {
            let l = &mut l.value;
            v.node(
                "limits",
                &mut With(|v: &mut dyn Visitor| {
                    v.required("lower", &mut l.lower, coordinate);
                    v.required("upper", &mut l.upper, coordinate);
                    v.scalar("e", &mut l.e, Dim::NONE, NONE);
                }),
            );
        }
        let clearance = self.kind.value == "revolute-clearance";
        let flange =
            Fallback::Rule("1.5 × journal_radius, at least journal_radius + 3 × clearance");
        for (name, q, dim, default) in [
            ("clearance", &mut self.clearance, L, REQUIRED),
            ("journal_radius", &mut self.journal_radius, L, REQUIRED),
            ("bore_length", &mut self.bore_length, L, REQUIRED),
            (
                "axial_play",
                &mut self.axial_play,
                L,
                Fallback::Value(AXIAL_PLAY),
            ),
            ("flange_radius", &mut self.flange_radius, L, flange),
            (
                "rim_points",
                &mut self.rim_points,
                Dim::NONE,
                Fallback::Value(RIM_POINTS as f64),
            ),
            ("mu", &mut self.mu, Dim::NONE, NONE),
            ("e", &mut self.e, Dim::NONE, NONE),
        ] {
            if clearance {
                v.scalar(name, q, dim, default);
            } else {
                let why = format!(
                    "joint `{}` is an ideal {} joint, which has no `{name}`; make it `revolute-clearance` to vary it",
                    self.name.value, self.kind.value
                );
                v.absent(name, &why);
            }
        }
        if let (true, Some(c)) = (clearance, &mut self.compliance) {
            v.node("compliance", &mut c.value);
        }
        // (a velocity drive, a position table)
        let drive = self.drive.as_ref().map(|d| {
            let d = &d.value;
            (d.velocity.is_some(), d.position_table.is_some())
        });
        let rate_dim = rate;
        let initial = self.initial.get_or_insert_with(|| {
            Spanned::new(InitialSpec::default(), Location::UNKNOWN, Location::UNKNOWN)
        });
        let i = &mut initial.value;
        v.node(
            "initial",
            &mut With(|v: &mut dyn Visitor| {
                if clearance {
                    v.vector("eccentricity", &mut i.eccentricity, L, Some(&ZERO));
                } else {
                    // a joint the scene does not start starts as the written poses and
                    // velocities do, once assembled; a driven one as its drive has it
                    let assembled = Fallback::Rule("as assembled");
                    let (start, rate) = match &drive {
                        Some((true, _)) => (assembled, Fallback::Rule("drive.velocity")),
                        Some((_, true)) => (DRIVE_TABLE, DRIVE_TABLE),
                        _ => (assembled, assembled),
                    };
                    let names = match prismatic {
                        true => [("position", &mut i.position), ("speed", &mut i.speed)],
                        false => [("angle", &mut i.angle), ("rate", &mut i.rate)],
                    };
                    let [(p, position), (r, speed)] = names;
                    v.scalar(p, position, coordinate, start);
                    v.scalar(r, speed, rate_dim, rate);
                }
            }),
        );
    }
}

/// A joint drive's numbers, those of the one kind it is, in the joint's (coordinate, rate,
/// effort) dimensions.
fn visit_drive(v: &mut dyn Visitor, d: &mut DriveSpec, dims: (Dim, Dim, Dim)) {
    let (coordinate, rate, effort) = dims;
    v.node(
        "drive",
        &mut With(|v: &mut dyn Visitor| {
            if d.velocity.is_some() {
                v.scalar("velocity", &mut d.velocity, rate, NONE);
            }
            v.table(
                "position_table",
                &mut d.position_table,
                &[Dim::TIME, coordinate],
            );
            if d.effort.is_some() {
                v.scalar("effort", &mut d.effort, effort, NONE);
            }
            v.table("effort_table", &mut d.effort_table, &[Dim::TIME, effort]);
        }),
    );
}

/// A box's numbers: its size, centre and orientation.
fn visit_box(
    v: &mut dyn Visitor,
    size: &mut Vector,
    center: &mut Option<Vector>,
    orientation: &mut Option<Spanned<OrientationSpec>>,
) {
    v.node(
        "box",
        &mut With(|v: &mut dyn Visitor| {
            v.required_vector("size", size, Dim::LENGTH);
            v.vector("center", center, Dim::LENGTH, Some(&ZERO));
            if let Some(o) = orientation {
                v.node("orientation", &mut o.value);
            }
        }),
    );
}

/// A convex part's numbers: its vertices, its mesh file's scale, its rounding.
fn visit_convex(
    v: &mut dyn Visitor,
    vertices: &mut Option<Spanned<Vec<Vec<Quantity>>>>,
    has_file: bool,
    scale: &mut Option<Q>,
    rounding: &mut Option<Q>,
) {
    const L: Dim = Dim::LENGTH;
    v.node(
        "convex",
        &mut With(|v: &mut dyn Visitor| {
            v.table("vertices", vertices, &[L, L, L]);
            if has_file {
                v.scalar("scale", scale, L, REQUIRED);
            }
            v.scalar("rounding", rounding, L, NONE);
        }),
    );
}

/// The paths of an `integrator` block's numbers (`integrator.h`, …), with the values it
/// gives.
pub fn integrator_paths(block: &IntegratorSpec) -> Vec<ParameterPath> {
    let mut lister = Lister {
        prefix: vec!["integrator".into()],
        out: Vec::new(),
    };
    block.clone().visit(&mut lister);
    lister.out
}

/// Every parameter path of `spec`, in document order.
pub(super) fn paths(spec: &SceneSpec) -> Vec<ParameterPath> {
    let mut lister = Lister {
        prefix: Vec::new(),
        out: Vec::new(),
    };
    spec.clone().visit(&mut lister);
    lister.out
}

/// The dimension of the number at `path`, writing `value` there if given; the error says
/// why the path names no number, with the nearest paths there are.
pub(super) fn find(spec: &mut SceneSpec, path: &str, value: Option<f64>) -> Result<Dim, String> {
    find_as(spec, path, value, false)
}

/// [`find`], writing the value with the path's unit when `with_unit`.
fn find_as(
    spec: &mut SceneSpec,
    path: &str,
    value: Option<f64>,
    with_unit: bool,
) -> Result<Dim, String> {
    let segments: Vec<&str> = path.split('.').collect();
    let mut finder = Finder {
        target: &segments,
        depth: 0,
        value,
        with_unit,
        found: None,
    };
    spec.visit(&mut finder);
    match finder.found {
        Some(Ok(dim)) => Ok(dim),
        Some(Err(why)) => Err(format!("parameter `{path}`: {why}")),
        None => Err(unknown(spec, path)),
    }
}

/// The error for a path that names nothing: the closest paths of the scene.
fn unknown(spec: &SceneSpec, path: &str) -> String {
    let all = paths(spec);
    let mut near: Vec<(usize, &str)> = all
        .iter()
        .map(|p| (edit_distance(path, &p.path), p.path.as_str()))
        .collect();
    near.sort();
    let list: Vec<&str> = near.iter().take(5).map(|(_, p)| *p).collect();
    format!(
        "unknown parameter path `{path}`; the nearest are: {} (`mc-study paths SCENE` lists them all)",
        list.join(", ")
    )
}

/// Levenshtein distance (characters).
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1)
                .min(row[j] + 1)
                .min(diag + usize::from(ca != cb));
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every bundled mechanism scene (a function scene is not one), with its file.
    fn bundled_specs() -> Vec<(std::path::PathBuf, SceneSpec)> {
        let studies = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies");
        let mut specs = Vec::new();
        for entry in std::fs::read_dir(studies).unwrap() {
            let path = entry.unwrap().path().join("scene.yaml");
            let text = std::fs::read_to_string(&path).unwrap();
            if let Ok(spec) = serde_saphyr::from_str::<SceneSpec>(&text) {
                specs.push((path, spec));
            }
        }
        specs
    }

    /// Every path of every bundled scene, written back with its value in the unit the path
    /// declares, is accepted by the builder, which checks units against what each field
    /// expects: the dimensions listed here agree with the builder's.
    #[test]
    fn declared_dimensions_agree_with_the_builder() {
        let mut checked = 0;
        for (path, spec) in bundled_specs() {
            for p in paths(&spec) {
                let mut s = spec.clone();
                let value = p.value.unwrap_or(1.0);
                find_as(&mut s, &p.path, Some(value), true).unwrap();
                if let Err(e) = super::super::build::build(s, "check", Vec::new()) {
                    assert!(
                        !e.message.contains("has a unit of"),
                        "{}: `{}` declared {}: {e}",
                        path.display(),
                        p.path,
                        p.dim.describe()
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 300, "only {checked} paths checked");
    }

    /// Every default `paths` states as a value, written into the bundled scene that leaves
    /// it out, builds the same model, integrator, phases and recording: the stated
    /// defaults are the builder's.
    #[test]
    fn stated_defaults_are_the_builder_s() {
        let built = |spec: SceneSpec| {
            let s = super::super::build::build(spec, "check", Vec::new()).unwrap();
            format!(
                "{:?}",
                (s.model, s.params, s.schedule, s.record_every, s.duration)
            )
        };
        let mut checked = 0;
        for (path, spec) in bundled_specs() {
            let base = built(spec.clone());
            for p in paths(&spec) {
                let (None, Fallback::Value(d)) = (p.value, p.default) else {
                    continue;
                };
                let mut s = spec.clone();
                find(&mut s, &p.path, Some(d)).unwrap();
                assert!(
                    built(s) == base,
                    "{}: `{}` written as its stated default {d} builds another scene",
                    path.display(),
                    p.path
                );
                checked += 1;
            }
        }
        assert!(checked > 100, "only {checked} defaults checked");
    }

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("anchor", "anchr"), 1);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
    }
}
