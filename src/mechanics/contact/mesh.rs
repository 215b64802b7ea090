//! Triangle meshes for fixed parts (a frame, a housing): a surface whose outward side is
//! given by its triangles' winding (counter-clockwise seen from outside). parry's BVH finds
//! the closest triangle; its pseudo-normals tell inside from outside at edges and corners.
//! A mesh is exact for what it is, a polyhedron: against a curved part it modelled, its
//! faceting error is the sagitta r (1 − cos(π / n)) ≈ r π² / (2 n²) of n facets per turn.

use super::convex::{from_parry, surface_at, to_parry, Surface};
use nalgebra::Vector3;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::FeatureId;
use parry3d_f64::shape::{TriMesh, TriMeshFlags};
use std::collections::HashSet;

#[derive(Clone)]
pub struct MeshPart {
    /// Vertices (body frame) and triangles, as read.
    pub vertices: Vec<Vector3<f64>>,
    pub triangles: Vec<[usize; 3]>,
    mesh: TriMesh,
}

impl std::fmt::Debug for MeshPart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "MeshPart({} vertices, {} triangles)",
            self.vertices.len(),
            self.triangles.len()
        )
    }
}

impl PartialEq for MeshPart {
    fn eq(&self, other: &Self) -> bool {
        self.vertices == other.vertices && self.triangles == other.triangles
    }
}

/// Checks a mesh: no degenerate triangle, every edge shared by at most two triangles,
/// and those two wound consistently (an edge walked once each way; three triangles on one
/// edge walk it twice the same way).
pub fn check(vertices: &[Vector3<f64>], triangles: &[[usize; 3]]) -> Result<(), String> {
    if triangles.is_empty() {
        return Err("the mesh has no triangles".into());
    }
    let scale = vertices.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let mut edges: HashSet<(usize, usize)> = HashSet::new();
    for (k, t) in triangles.iter().enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i >= vertices.len()) {
            return Err(format!(
                "triangle {k} names vertex {i}, which does not exist"
            ));
        }
        let [a, b, c] = t.map(|i| vertices[i]);
        if (b - a).cross(&(c - a)).norm() <= 1e-12 * scale * scale {
            return Err(format!("triangle {k} is degenerate (zero area)"));
        }
        for (i, j) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            if !edges.insert((i, j)) {
                return Err(format!(
                    "the mesh is not manifold or not consistently wound: edge {i}–{j} is walked twice the same way (triangle {k})"
                ));
            }
        }
    }
    Ok(())
}

/// Checks that a closed, checked mesh is convex: every vertex on or behind every
/// triangle's plane.
pub fn check_convex(vertices: &[Vector3<f64>], triangles: &[[usize; 3]]) -> Result<(), String> {
    // the part's own size, not its distance from the origin; a binary STL rounds each
    // coordinate to 32 bits, which leaves a convex part's vertices up to about 1e-7 of
    // that size off its faces
    let centre = vertices.iter().sum::<Vector3<f64>>() / vertices.len().max(1) as f64;
    let size = vertices
        .iter()
        .map(|v| (v - centre).norm())
        .fold(0.0, f64::max);
    let tolerance = 1e-6 * size + 4.0 * f64::from(f32::EPSILON) * centre.norm();
    for (k, t) in triangles.iter().enumerate() {
        let [a, b, c] = t.map(|i| vertices[i]);
        let n = (b - a).cross(&(c - a)).normalize();
        if let Some(v) = vertices.iter().position(|v| n.dot(&(v - a)) > tolerance) {
            return Err(format!(
                "the mesh is not convex: vertex {v} lies outside the plane of triangle {k}"
            ));
        }
    }
    Ok(())
}

impl MeshPart {
    /// Checks (`check`) and indexes a mesh.
    pub fn new(vertices: Vec<Vector3<f64>>, triangles: Vec<[usize; 3]>) -> Result<Self, String> {
        check(&vertices, &triangles)?;
        let mesh = TriMesh::with_flags(
            vertices.iter().map(to_parry).collect(),
            triangles.iter().map(|t| t.map(|i| i as u32)).collect(),
            TriMeshFlags::HALF_EDGE_TOPOLOGY | TriMeshFlags::ORIENTED,
        )
        .map_err(|e| format!("parry refuses the mesh: {e}"))?;
        Ok(MeshPart {
            vertices,
            triangles,
            mesh,
        })
    }

    /// The closest point of the surface to `x` (body frame), the signed distance (< 0
    /// behind the surface) and the outward normal.
    pub fn surface(&self, x: &Vector3<f64>) -> Surface {
        let (proj, feature) = self.mesh.project_local_point_and_get_feature(to_parry(x));
        let t = self.triangles[proj.subshape as usize].map(|i| self.vertices[i]);
        if let FeatureId::Face(_) = feature {
            // on a face: its plane, exact however close x is, and signed by it
            let n = (t[1] - t[0]).cross(&(t[2] - t[0])).normalize();
            return surface_at(x, t[0], Some((n, n.dot(&t[0]))));
        }
        let s = surface_at(x, from_parry(proj.point), None);
        if proj.is_inside {
            Surface {
                distance: -s.distance,
                normal: -s.normal,
                ..s
            }
        } else {
            s
        }
    }
}
