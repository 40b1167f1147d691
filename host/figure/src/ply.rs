//! The indented surface as a PLY mesh (ASCII), for MeshLab, Blender or Open3D: one vertex
//! per depth cell at `(x, y, −depth)` in mm (y down the image, z out of the skin), two
//! triangles per square of four trusted cells. Untrusted cells are left out, with every
//! triangle that would touch them.

use std::io::Write;
use std::path::Path;

use crate::{FigureError, Grid};

/// Writes `depth` (mm) as a PLY mesh to `path`.
pub fn write(depth: &Grid, path: &Path) -> Result<(), FigureError> {
    if !depth.is_consistent() {
        return Err(FigureError::Data(format!(
            "depth map {}×{} has {} values",
            depth.width,
            depth.height,
            depth.values.len()
        )));
    }
    let io = |source| FigureError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    out.write_all(&mesh(depth)).map_err(io)?;
    out.flush().map_err(io)
}

/// The PLY text of `depth`.
pub fn mesh(depth: &Grid) -> Vec<u8> {
    let w = depth.width;
    let mut index = vec![None; depth.values.len()];
    let mut vertices = String::new();
    let mut n = 0usize;
    for (i, &v) in depth.values.iter().enumerate() {
        if v.is_finite() {
            index[i] = Some(n);
            n += 1;
            let (x, y) = (
                (i % w) as f64 * depth.pitch_mm,
                (i / w) as f64 * depth.pitch_mm,
            );
            vertices.push_str(&format!("{x:.4} {y:.4} {:.4}\n", -v));
        }
    }
    let mut faces = String::new();
    let mut f = 0usize;
    for y in 0..depth.height.saturating_sub(1) {
        for x in 0..w.saturating_sub(1) {
            let at = |dx: usize, dy: usize| index[(y + dy) * w + x + dx];
            if let (Some(a), Some(b), Some(c), Some(d)) = (at(0, 0), at(1, 0), at(1, 1), at(0, 1)) {
                faces.push_str(&format!("3 {a} {b} {c}\n3 {a} {c} {d}\n"));
                f += 2;
            }
        }
    }
    let header = format!(
        "ply\nformat ascii 1.0\ncomment vistaf indented surface, mm\n\
         element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {f}\nproperty list uchar int vertex_indices\nend_header\n"
    );
    [header, vertices, faces].concat().into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hole_leaves_out_its_triangles() {
        let g = Grid {
            width: 3,
            height: 3,
            pitch_mm: 0.5,
            values: vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, f32::NAN],
        };
        let text = String::from_utf8(mesh(&g)).unwrap();
        assert!(text.contains("element vertex 8\n"));
        // Four squares, the one touching the untrusted corner left out.
        assert!(text.contains("element face 6\n"));
        assert!(text.contains("0.5000 0.5000 -1.0000\n"));
    }
}
