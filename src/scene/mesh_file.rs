//! Reading triangle meshes from CAD exports: STL (binary or ASCII) and Wavefront OBJ
//! (`v` and `f` lines; faces of more than three vertices are fanned). Vertices at the same
//! coordinates are merged, since STL repeats them per facet. A file is read only if it is
//! a regular file of bounded size, and every coordinate must be a finite number within
//! reach of a mechanism, so that a NaN or a unit error is named where it is.

use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::Path;

/// The largest mesh file read: a CAD part of a mechanism is far below (a 1-million-facet
/// binary STL is 50 MB).
pub const MAX_BYTES: u64 = 256 << 20;

/// The farthest a vertex may lie from the origin, in metres: beyond, the file's unit or
/// `scale` is wrong.
pub const MAX_REACH: f64 = 1e4;

/// A mesh as read: its vertices and its triangles (vertex indices).
pub type Triangles = (Vec<Vector3<f64>>, Vec<[usize; 3]>);

/// Vertices (file units times `scale`) and triangles of a mesh file.
pub fn read(path: &Path, scale: f64) -> Result<Triangles, String> {
    let bytes =
        bounded(path).map_err(|e| format!("cannot read mesh file {}: {e}", path.display()))?;
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
    for (k, t) in soup.iter().enumerate() {
        for (v, c) in t.iter().enumerate() {
            let far = c.iter().map(|x| (x * scale).abs()).fold(0.0, f64::max);
            if far > MAX_REACH {
                return Err(format!(
                    "{}: triangle {k}, vertex {v} lies at {:e} m from the origin (beyond {MAX_REACH:e} m): is `scale` or the file's unit wrong?",
                    path.display(),
                    far
                ));
            }
        }
    }
    Ok(weld(soup, scale))
}

/// The bytes of a regular file of at most [`MAX_BYTES`]; a device, a FIFO or a larger file
/// is refused without reading it.
fn bounded(path: &Path) -> Result<Vec<u8>, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let meta = file.metadata().map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a regular file (a device, a FIFO or a directory)".into());
    }
    crate::input::file::read_at_most(file, MAX_BYTES, "not a mechanism part")
}

/// A coordinate read from a file: finite, or an error naming where it is.
fn finite(x: f64, place: impl Fn() -> String) -> Result<f64, String> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!(
            "{}: the coordinate {x} is not a finite number",
            place()
        ))
    }
}

/// Triangles as corner coordinates.
type Soup = Vec<[[f64; 3]; 3]>;

fn stl(bytes: &[u8]) -> Result<Soup, String> {
    // a binary STL is 84 + 50 n bytes; an ASCII one starts with `solid` and has facets
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
        if bytes.len() == 84 + 50 * n {
            let mut soup = Vec::with_capacity(n);
            for k in 0..n {
                let f = &bytes[84 + 50 * k + 12..84 + 50 * k + 48];
                let mut t = [[0.0; 3]; 3];
                for (v, corner) in t.iter_mut().enumerate() {
                    for (i, x) in corner.iter_mut().enumerate() {
                        let j = 4 * (3 * v + i);
                        let read = f32::from_le_bytes(f[j..j + 4].try_into().unwrap());
                        *x = finite(read as f64, || format!("facet {k}, vertex {v}"))?;
                    }
                }
                soup.push(t);
            }
            return Ok(soup);
        }
    }
    let text = std::str::from_utf8(bytes).map_err(|_| "neither a binary nor an ASCII STL")?;
    let mut soup = Vec::new();
    let mut corners = Vec::new();
    let (mut facets, mut closed) = (0usize, 0usize);
    let mut last = "";
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let first = words.next();
        match first {
            Some("vertex") => {
                corners.push(coordinates(words, n + 1)?);
                if corners.len() == 3 {
                    soup.push([corners[0], corners[1], corners[2]]);
                    corners.clear();
                }
            }
            Some("facet") => facets += 1,
            Some("endfacet") => closed += 1,
            _ => {}
        }
        if let Some(w) = first {
            last = w;
        }
    }
    if soup.is_empty() {
        return Err("no facets".into());
    }
    // a file cut short (a transfer or an export that stopped) must not pass as a smaller part
    if last != "endsolid" || !corners.is_empty() || facets != closed || facets != soup.len() {
        return Err(format!(
            "a truncated or malformed ASCII STL: {} facets begun, {} ended, {} with three vertices{}",
            facets,
            closed,
            soup.len(),
            if last != "endsolid" { ", and no `endsolid` at the end" } else { "" }
        ));
    }
    Ok(soup)
}

/// The three coordinates of a vertex from the words after its keyword, on line `line`.
fn coordinates<'a>(words: impl Iterator<Item = &'a str>, line: usize) -> Result<[f64; 3], String> {
    let v: Vec<f64> = words
        .map(|w| w.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("line {line}: {e}"))?;
    for x in &v {
        finite(*x, || format!("line {line}"))?;
    }
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
