//! Reading triangle meshes from CAD exports: STL (binary or ASCII) and Wavefront OBJ
//! (`v` and `f` lines; faces of more than three vertices are fanned). Vertices at the same
//! coordinates are merged, since STL repeats them per facet.

use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::Path;

/// A mesh as read: its vertices and its triangles (vertex indices).
pub type Triangles = (Vec<Vector3<f64>>, Vec<[usize; 3]>);

/// Vertices (file units times `scale`) and triangles of a mesh file.
pub fn read(path: &Path, scale: f64) -> Result<Triangles, String> {
    let bytes = std::fs::read(path)
        .map_err(|e| format!("cannot read mesh file {}: {e}", path.display()))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let soup = match ext.as_deref() {
        Some("stl") => stl(&bytes),
        Some("obj") => obj(&bytes),
        _ => Err("unknown mesh format (expected .stl or .obj)".into()),
    }
    .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(weld(soup, scale))
}

/// Triangles as corner coordinates.
type Soup = Vec<[[f64; 3]; 3]>;

fn stl(bytes: &[u8]) -> Result<Soup, String> {
    // a binary STL is 84 + 50 n bytes; an ASCII one starts with `solid` and has facets
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
        if bytes.len() == 84 + 50 * n {
            return Ok((0..n)
                .map(|k| {
                    let f = &bytes[84 + 50 * k + 12..84 + 50 * k + 48];
                    let c = |i: usize| {
                        f32::from_le_bytes(f[4 * i..4 * i + 4].try_into().unwrap()) as f64
                    };
                    [0, 1, 2].map(|v| [c(3 * v), c(3 * v + 1), c(3 * v + 2)])
                })
                .collect());
        }
    }
    let text = std::str::from_utf8(bytes).map_err(|_| "neither a binary nor an ASCII STL")?;
    let mut soup = Vec::new();
    let mut corners = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() == Some("vertex") {
            corners.push(coordinates(words, n + 1)?);
            if corners.len() == 3 {
                soup.push([corners[0], corners[1], corners[2]]);
                corners.clear();
            }
        }
    }
    if soup.is_empty() {
        return Err("no facets".into());
    }
    Ok(soup)
}

/// The three coordinates of a vertex from the words after its keyword, on line `line`.
fn coordinates<'a>(words: impl Iterator<Item = &'a str>, line: usize) -> Result<[f64; 3], String> {
    let v: Vec<f64> = words
        .map(|w| w.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("line {line}: {e}"))?;
    match v[..] {
        [x, y, z] => Ok([x, y, z]),
        _ => Err(format!("line {line}: a vertex needs 3 coordinates")),
    }
}

fn obj(bytes: &[u8]) -> Result<Soup, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "not a text OBJ file")?;
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut soup = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            // an OBJ vertex may carry a fourth, weight, coordinate
            Some("v") => vertices.push(coordinates(words.take(3), n + 1)?),
            Some("f") => {
                let idx: Vec<usize> = words
                    .map(|w| {
                        let i: i64 = w
                            .split('/')
                            .next()
                            .unwrap_or("")
                            .parse()
                            .map_err(|e| format!("line {}: {e}", n + 1))?;
                        let k = if i < 0 {
                            vertices.len() as i64 + i
                        } else {
                            i - 1
                        };
                        usize::try_from(k)
                            .ok()
                            .filter(|&k| k < vertices.len())
                            .ok_or(format!("line {}: no vertex {i}", n + 1))
                    })
                    .collect::<Result<_, _>>()?;
                if idx.len() < 3 {
                    return Err(format!("line {}: a face needs 3 vertices", n + 1));
                }
                for k in 1..idx.len() - 1 {
                    soup.push([vertices[idx[0]], vertices[idx[k]], vertices[idx[k + 1]]]);
                }
            }
            _ => {}
        }
    }
    if soup.is_empty() {
        return Err("no faces".into());
    }
    Ok(soup)
}

/// Shared vertices for a triangle soup (exactly equal coordinates merge).
fn weld(soup: Soup, scale: f64) -> Triangles {
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    let mut vertices = Vec::new();
    let triangles = soup
        .iter()
        .map(|t| {
            t.map(|v| {
                *index.entry(v.map(f64::to_bits)).or_insert_with(|| {
                    vertices.push(Vector3::from(v) * scale);
                    vertices.len() - 1
                })
            })
        })
        .collect();
    (vertices, triangles)
}
