//! The scene YAML schema, as serde structs. Every scalar the user writes is kept with its
//! source location (`Spanned`) so that validation errors can name the line.

use crate::input::units::Quantity;
use serde::Deserialize;
use serde_saphyr::Spanned;

pub type Q = Spanned<Quantity>;
pub type Vector = Spanned<Vec<Quantity>>;
pub type Name = Spanned<String>;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// `mechanism` (the default); analytic scenes say `function` (see `function.rs`).
    #[serde(rename = "type")]
    pub kind: Option<Name>,
    pub name: Option<String>,
    pub description: Option<String>,
    /// Simulated time span.
    pub duration: Q,
    /// Default (0, 0, −9.81) m/s².
    pub gravity: Option<Vector>,
    /// `xy`, `xz` or `yz`: every moving body is held to that plane of the world.
    pub plane: Option<Name>,
    #[serde(default)]
    pub integrator: IntegratorSpec,
    pub bodies: Vec<BodySpec>,
    #[serde(default)]
    pub contacts: Vec<ContactSpec>,
    #[serde(default)]
    pub forces: Vec<ForceSpec>,
    #[serde(default)]
    pub joints: Vec<JointSpec>,
    #[serde(default)]
    pub record: RecordSpec,
    /// A settling phase at the start of the run (a preloaded mechanism's assembly).
    pub settle: Option<Spanned<SettleSpec>>,
    /// A window of finer steps opened by a contact's first closing.
    pub refine: Option<Spanned<RefineSpec>>,
    /// Named outputs of a run (the study's outputs).
    #[serde(default)]
    pub probes: Vec<ProbeSpec>,
}

/// An ideal joint. The anchor and axis are given either in world coordinates at the
/// assembled configuration (`anchor`, `axis`) or in each body's frame
/// (`anchor_a`/`anchor_b`, `axis_a`/`axis_b`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    pub name: Name,
    /// `revolute`, `prismatic`, `spherical` or `fixed`.
    #[serde(rename = "type")]
    pub kind: Name,
    pub body_a: Name,
    pub body_b: Name,
    pub anchor: Option<Vector>,
    pub axis: Option<Vector>,
    pub anchor_a: Option<Vector>,
    pub anchor_b: Option<Vector>,
    pub axis_a: Option<Vector>,
    pub axis_b: Option<Vector>,
    pub drive: Option<Spanned<DriveSpec>>,
    /// Stops on the joint coordinate (revolute: angle, prismatic: displacement, from the
    /// assembled configuration).
    pub limits: Option<Spanned<LimitsSpec>>,
    /// Clearance geometry, used by `revolute-clearance` (body_a carries the bore, body_b the
    /// journal) and ignored by the ideal `revolute`, so switching is one word.
    pub clearance: Option<Q>,
    pub journal_radius: Option<Q>,
    pub bore_length: Option<Q>,
    /// Total axial play (default 0.1 mm).
    pub axial_play: Option<Q>,
    /// Flange rim radius (default 1.5 × journal radius).
    pub flange_radius: Option<Q>,
    /// Rim points per flange side (default 4).
    pub rim_points: Option<Q>,
    pub mu: Option<Q>,
    pub e: Option<Q>,
    /// A revolute-clearance joint's radial contact: `rigid` (default) or `compliant`.
    pub law: Option<Name>,
    pub compliance: Option<Spanned<ComplianceSpec>>,
    /// Joint-space initial condition, which the assembly meets.
    pub initial: Option<Spanned<InitialSpec>>,
}

/// The initial state of a joint at t = 0: revolute `angle`, `rate` and prismatic
/// `position`, `speed` (the coordinate from the written configuration and its rate); a
/// revolute-clearance joint's `eccentricity` (the journal's offset from the bore axis, in
/// the bore body's frame; default: centred).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    pub angle: Option<Q>,
    pub rate: Option<Q>,
    pub position: Option<Q>,
    pub speed: Option<Q>,
    pub eccentricity: Option<Vector>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSpec {
    pub lower: Q,
    pub upper: Q,
    /// Restitution of the stops (default 0).
    pub e: Option<Q>,
}

/// Exactly one of: `velocity` (constant rate of the joint coordinate from assembly),
/// `position_table` (rows [t, q]), `effort` (torque or force), `effort_table` (rows [t, f]).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveSpec {
    pub velocity: Option<Q>,
    pub position_table: Option<Spanned<Vec<Vec<Quantity>>>>,
    pub effort: Option<Q>,
    pub effort_table: Option<Spanned<Vec<Vec<Quantity>>>>,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `fast`, `balanced` or `accurate`: scales the scene's own settings (`Preset`), before
    /// the other keys of the block apply.
    pub preset: Option<Name>,
    pub h: Option<Q>,
    pub theta: Option<Q>,
    pub gamma: Option<Q>,
    pub scheme: Option<Name>,
    pub activation_margin: Option<Q>,
    pub solver: Option<ToleranceSpec>,
    pub newton: Option<ToleranceSpec>,
    pub projection: Option<ToleranceSpec>,
    /// Split a step at the first contact that closes in it (default false).
    pub locate_impacts: Option<bool>,
    /// Error-controlled step size, or `off` (`StepControl`).
    pub step_control: Option<StepControlSpec>,
}

/// `step_control: { tolerance: 1e-4, h_max: 1 ms, … }`, or `step_control: off` (a study's
/// fidelity block that runs a controlled scene at a fixed step).
#[derive(Clone, Debug)]
pub enum StepControlSpec {
    On(Box<StepControlBlock>),
    Off,
}

/// A word or a block, each read by the YAML reader itself, which keeps the lines of the
/// block's values (an untagged enum would buffer them and lose their lines).
impl<'de> Deserialize<'de> for StepControlSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Either;
        impl<'de> serde::de::Visitor<'de> for Either {
            type Value = StepControlSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("`off` or a block such as { tolerance: 1e-4, h_max: 1 ms }")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
                match v {
                    "off" => Ok(StepControlSpec::Off),
                    _ => Err(E::custom(format!(
                        "`step_control` must be `off` or a block such as {{ tolerance: 1e-4, h_max: 1 ms }}, got `{v}`"
                    ))),
                }
            }
            fn visit_bool<E: serde::de::Error>(self, v: bool) -> Result<Self::Value, E> {
                // YAML 1.1 reads a bare `off` as false
                match v {
                    false => self.visit_str("off"),
                    true => self.visit_str("on"),
                }
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<Self::Value, A::Error> {
                let d = serde::de::value::MapAccessDeserializer::new(map);
                StepControlBlock::deserialize(d).map(|b| StepControlSpec::On(Box::new(b)))
            }
        }
        d.deserialize_any(Either)
    }
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepControlBlock {
    pub tolerance: Option<Q>,
    pub h_max: Option<Q>,
    pub h_min: Option<Q>,
    pub length: Option<Q>,
    pub speed: Option<Q>,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToleranceSpec {
    pub tolerance: Option<Q>,
    pub max_iterations: Option<Q>,
}

/// Until `until`, every moving body is damped by −`damping` · M v, and only the contact
/// pairs and clearance joints listed in `friction` (default: all) keep their friction
/// (`mechanics::Settle`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SettleSpec {
    pub until: Q,
    /// α, a rate (1/s), default 0.
    pub damping: Option<Q>,
    pub friction: Option<Spanned<Vec<Name>>>,
    /// The step while settling (default: the integrator's h).
    pub h: Option<Q>,
    /// The contact solver's tolerance while settling (default: the integrator's).
    pub tolerance: Option<Q>,
}

/// From the first closing of contact `after`, the step is `h` for `for`, or until the
/// event probe `until` happens if it does sooner (`integrator::Refine`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefineSpec {
    pub after: Name,
    #[serde(rename = "for")]
    pub duration: Q,
    pub h: Q,
    pub until: Option<Name>,
    /// The step before the window opens (default: the integrator's).
    pub approach: Option<Q>,
    /// Run the window at `h` and at h/2 and extrapolate the probes (default false).
    #[serde(default)]
    pub extrapolate: bool,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordSpec {
    /// Record every n-th step (default 1).
    pub every: Option<Q>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: Name,
    pub mass: Option<Q>,
    /// Principal moments [Ixx, Iyy, Izz] or the 9 entries of the tensor, row by row.
    pub inertia: Option<Vector>,
    /// Solid whose inertia is derived from the mass when `inertia` is absent.
    pub shape: Option<Spanned<ShapeSpec>>,
    pub position: Option<Vector>,
    pub orientation: Option<Spanned<OrientationSpec>>,
    pub velocity: Option<Vector>,
    /// Body frame.
    pub angular_velocity: Option<Vector>,
    /// `free` (default), `pinned` (reference point fixed) or `fixed`.
    pub motion: Option<Name>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
pub enum ShapeSpec {
    Box { size: Vector },
    Cylinder { radius: Q, length: Q },
    Sphere { radius: Q },
}

/// Exactly one of: `axis` + `angle`, `quaternion` [w, x, y, z], `rotation_vector`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrientationSpec {
    pub axis: Option<Vector>,
    pub angle: Option<Q>,
    pub quaternion: Option<Vector>,
    pub rotation_vector: Option<Vector>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    pub name: Option<String>,
    pub body: Name,
    pub shape: Spanned<PrimitiveSpec>,
    /// Other body (default `ground`).
    pub against: Option<Name>,
    pub against_shape: Spanned<PrimitiveSpec>,
    /// Coulomb coefficient (default 0).
    pub mu: Option<Q>,
    /// Newton restitution coefficient (default 0).
    pub e: Option<Q>,
    /// `rigid` (default) or `compliant`.
    pub law: Option<Name>,
    /// The compliant law's data (`law: compliant`).
    pub compliance: Option<Spanned<ComplianceSpec>>,
}

/// A compliant contact's force K δⁿ (1 + D δ̇): K from the materials (Hertz) or given.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComplianceSpec {
    /// The first body's material (and the second's, unless `against_material` is given).
    pub material: Option<Spanned<MaterialSpec>>,
    pub against_material: Option<Spanned<MaterialSpec>>,
    /// K in SI units (N/mⁿ), instead of the materials.
    pub stiffness: Option<Q>,
    /// n (default 1.5, Hertz's).
    pub exponent: Option<Q>,
    /// `matched` (default: D solved for so that an impact restitutes e), `flores` or
    /// `hunt-crossley`.
    pub dissipation: Option<Name>,
    /// The regularised friction's slip speed v_ε (default 0.1 mm/s).
    pub slip_speed: Option<Q>,
}

/// An elastic material: Young's modulus and Poisson's ratio.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    #[serde(rename = "E")]
    pub youngs_modulus: Q,
    pub nu: Q,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
#[allow(clippy::large_enum_variant)] // parsed once per scene; boxing would only obscure the schema
pub enum PrimitiveSpec {
    Sphere {
        radius: Q,
        center: Option<Vector>,
    },
    Plane {
        point: Option<Vector>,
        normal: Vector,
    },
    Box {
        size: Vector,
        center: Option<Vector>,
        orientation: Option<Spanned<OrientationSpec>>,
    },
    Cylinder {
        radius: Q,
        length: Q,
        axis: Option<Vector>,
        center: Option<Vector>,
    },
    Capsule {
        radius: Q,
        length: Q,
        axis: Option<Vector>,
        center: Option<Vector>,
    },
    /// A solid cone: its base (of `radius`) at −length/2 along `axis` from `center`, its
    /// apex at +length/2.
    Cone {
        radius: Q,
        length: Q,
        axis: Option<Vector>,
        center: Option<Vector>,
    },
    Point {
        position: Vector,
    },
    Profile(ProfileSpec),
    /// A convex polyhedron: the hull of `vertices` (rows [x, y, z], body frame), which must
    /// all be its vertices, or of the mesh in `file` (STL or OBJ, relative to the scene),
    /// which must be convex; `scale` is the length of one file unit (`1 mm`).
    Convex {
        vertices: Option<Spanned<Vec<Vec<Quantity>>>>,
        file: Option<Name>,
        scale: Option<Q>,
        /// Radius of the rounding of its edges and corners (default 0).
        rounding: Option<Q>,
    },
    /// A triangle mesh from `file` (STL or OBJ, relative to the scene), for a fixed part;
    /// `scale` as for `convex`.
    Mesh {
        file: Name,
        scale: Q,
    },
}

/// A planar profile of segments and arcs in a plane of the body, extruded along the
/// plane's normal: `plane` `xy` (default), `yz` or `xz` names the body axes (u, v) its
/// coordinates are along, and `offset` moves it along the normal (u × v).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileSpec {
    pub plane: Option<Name>,
    pub offset: Option<Q>,
    pub thickness: Q,
    /// The path's first point; not for a path that is one `circle`.
    pub start: Option<Vector>,
    pub path: Spanned<Vec<Spanned<PieceSpec>>>,
    /// `inside` (default) or `outside` a closed profile; `left` or `right` of an open one.
    pub solid: Option<Name>,
}

/// One piece of a profile path: `line: [u, v]` (to that point), or
/// `arc: { to: [u, v], center: [u, v], direction: ccw | cw }` (default ccw); or, as the
/// whole path, `circle: { center: [u, v], radius }` (a round cam, a hole).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
pub enum PieceSpec {
    Line(Vector),
    Arc {
        to: Vector,
        center: Vector,
        direction: Option<Name>,
    },
    Circle {
        center: Vector,
        radius: Q,
    },
}

/// A force element: exactly one of `spring`, `torsional_spring`, `load`, with an optional
/// `name` that addresses it in parameter paths (`forces.<name>.spring.stiffness`; unnamed
/// forces go by index, `forces.0.spring.stiffness`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceSpec {
    pub name: Option<Name>,
    pub spring: Option<Spanned<SpringSpec>>,
    pub torsional_spring: Option<Spanned<TorsionalSpec>>,
    pub load: Option<Spanned<LoadSpec>>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    pub body_a: Name,
    pub point_a: Option<Vector>,
    pub body_b: Name,
    pub point_b: Option<Vector>,
    pub stiffness: Q,
    pub damping: Option<Q>,
    /// Default: the initial distance.
    pub rest_length: Option<Q>,
    pub preload: Option<Q>,
    /// The preload rises linearly from zero over this time (default: applied at once).
    pub ramp: Option<Q>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TorsionalSpec {
    pub body_a: Name,
    pub body_b: Name,
    /// Axis in body a's frame.
    pub axis: Vector,
    pub stiffness: Q,
    pub damping: Option<Q>,
    pub preload: Option<Q>,
    /// Angle (from the written configuration) at which the moment is the preload alone.
    pub rest_angle: Option<Q>,
    /// The same, measured from the two bodies' frames aligned (not with `rest_angle`).
    pub free_angle: Option<Q>,
    /// The preload rises linearly from zero over this time (default: applied at once).
    pub ramp: Option<Q>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    pub body: Name,
    /// Point of application, body frame (default: the reference point).
    pub point: Option<Vector>,
    /// Constant force.
    pub force: Option<Vector>,
    /// Piecewise-linear force: rows [t, fx, fy, fz].
    pub force_table: Option<Spanned<Vec<Vec<Quantity>>>>,
    pub torque: Option<Vector>,
    pub torque_table: Option<Spanned<Vec<Vec<Quantity>>>>,
    /// `world` (default) or `body`.
    pub frame: Option<Name>,
}

/// A named output of a run: the time of an `event`, or a `measure` taken `at` a time or
/// event (default: the end of the run) or reduced (`max`, `min`, `mean`) over the window
/// [`from`, `to`] (default: the whole run).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    pub name: Name,
    pub event: Option<Spanned<EventSpec>>,
    pub measure: Option<Spanned<MeasureSpec>>,
    /// One probe's measure against another's, resampled on a grid of the first.
    pub curve: Option<Spanned<CurveSpec>>,
    /// With `curve`: a CSV file of measured points (x, y), relative to the scene file, for
    /// the report to draw over the study's curves and compare with.
    pub reference: Option<Name>,
    /// `at` (default), `max`, `min`, `mean` or `sum`.
    pub reduce: Option<Name>,
    pub at: Option<Spanned<TimeRef>>,
    pub from: Option<Spanned<TimeRef>>,
    pub to: Option<Spanned<TimeRef>>,
    /// With `reduce: max` or `min`: the peak of the measure's mean over a trailing window
    /// of this duration (a quasi-static peak, which converges as the step falls).
    pub mean_over: Option<Q>,
    /// The output may have no value (its event may not happen): a run without it keeps its
    /// other outputs.
    #[serde(default)]
    pub optional: bool,
    /// The unit the summary and the report show the value in (default: chosen from the
    /// values), e.g. `mm`, `N*mm`, `deg`.
    pub unit: Option<Name>,
}

/// `curve: { x: PROBE, y: PROBE, grid: "0 mm .. 6 mm step 0.05 mm" }`: the measure of
/// value probe `y` against that of value probe `x`, on a grid of x's values.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    pub x: Name,
    pub y: Name,
    pub grid: Name,
}

/// Exactly one of: `closes: CONTACT` (its normal impulse becomes positive), `opens:
/// CONTACT` (its normal impulse returns to zero), or `crosses: VALUE` of `measure`
/// (linearly interpolated between steps). `occurrence` counts from 1.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventSpec {
    pub closes: Option<Name>,
    pub opens: Option<Name>,
    pub crosses: Option<Q>,
    pub measure: Option<Spanned<MeasureSpec>>,
    /// For `crosses`: `up`, `down` or `either` (default).
    pub direction: Option<Name>,
    pub occurrence: Option<Q>,
}

/// Exactly one quantity (`probes.rs` lists them), and for the vector quantities an `axis`
/// (a component along it; default: the magnitude) with the `frame` that carries it, or
/// `angle_from` (the direction's angle about a joint's axis from a reference direction).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasureSpec {
    pub gap: Option<Name>,
    pub contact_force: Option<Name>,
    pub impulse: Option<Name>,
    pub distance: Option<Spanned<DistanceSpec>>,
    pub angle: Option<Name>,
    pub displacement: Option<Name>,
    pub velocity: Option<Spanned<PointRefSpec>>,
    pub angular_velocity: Option<Name>,
    pub reaction: Option<Name>,
    pub reaction_torque: Option<Name>,
    pub drive_effort: Option<Name>,
    pub eccentricity: Option<Name>,
    pub axis: Option<Vector>,
    pub frame: Option<Name>,
    pub angle_from: Option<Vector>,
    /// Where a joint `angle` is zero: `written` (the written configuration, the default)
    /// or `frames` (the two bodies' frames aligned).
    pub zero: Option<Name>,
}

/// (p_to − p_from) · axis, with the axis fixed in the world (default) or in a body's frame.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DistanceSpec {
    pub from: PointRefSpec,
    pub to: PointRefSpec,
    pub axis: Vector,
    /// `world` (default) or the name of the body whose frame carries the axis.
    pub frame: Option<Name>,
}

/// A point fixed in a body (body frame) or in the world (`ground`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointRefSpec {
    pub body: Name,
    pub point: Option<Vector>,
}

/// A time: a quantity ("20 ms") or the name of an event probe.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeRef {
    Time(Quantity),
    Probe(String),
}

impl<'de> Deserialize<'de> for TimeRef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = TimeRef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a time (\"20 ms\") or the name of an event probe")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<TimeRef, E> {
                Ok(TimeRef::Time(Quantity { si: v, dim: None }))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<TimeRef, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<TimeRef, E> {
                self.visit_f64(v as f64)
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<TimeRef, E> {
                Ok(match crate::input::units::parse_quantity(v) {
                    Ok(q) => TimeRef::Time(q),
                    Err(_) => TimeRef::Probe(v.trim().to_string()),
                })
            }
        }
        d.deserialize_any(V)
    }
}
