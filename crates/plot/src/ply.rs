//! A PLY 1.0 writer (binary little-endian) for point clouds with per-vertex scalar properties:
//! `grid.ply` (the grid points with their σ) and `trajectories.ply` (the measured markers), for
//! CloudCompare, Open3D or MeshLab.
//!
//! One `vertex` element, no faces; every property a scalar (`double`, `float`, `int` or
//! `uint`); comment lines in the header. A row is given as `f64` values and stored in its
//! column's type (`float`: rounded to the nearest `f32`; `int`/`uint`: the value must be an
//! integer in range).
//!
//! ```
//! use crashrig_plot::ply::{PlyType, PlyVertices};
//!
//! let mut ply = PlyVertices::new(&[("x", PlyType::Double), ("sigma", PlyType::Float)]);
//! ply.comment("two points");
//! ply.push(&[1.5, 0.25]);
//! ply.push(&[2.0, f64::NAN]);
//! let bytes = ply.to_bytes();
//! assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\ncomment two points\n"));
//! assert_eq!(bytes.len(), ply.header().len() + 2 * (8 + 4));
//! ```

use std::fmt::Write as _;

/// The scalar type of a PLY property.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlyType {
    /// 8-byte IEEE float (`double`).
    Double,
    /// 4-byte IEEE float (`float`).
    Float,
    /// 4-byte signed integer (`int`).
    Int,
    /// 4-byte unsigned integer (`uint`).
    UInt,
}

impl PlyType {
    /// The type's name in a PLY header.
    pub fn name(self) -> &'static str {
        match self {
            PlyType::Double => "double",
            PlyType::Float => "float",
            PlyType::Int => "int",
            PlyType::UInt => "uint",
        }
    }
}

/// The vertices of a PLY file being built: properties, comments and the binary body.
#[derive(Debug, Clone)]
pub struct PlyVertices {
    properties: Vec<(String, PlyType)>,
    comments: Vec<String>,
    body: Vec<u8>,
    count: usize,
}

impl PlyVertices {
    /// An empty vertex list with these properties (name, type), in order.
    pub fn new(properties: &[(&str, PlyType)]) -> PlyVertices {
        PlyVertices {
            properties: properties
                .iter()
                .map(|(n, t)| ((*n).to_string(), *t))
                .collect(),
            comments: Vec::new(),
            body: Vec::new(),
            count: 0,
        }
    }

    /// Adds a comment line to the header (line breaks become spaces).
    pub fn comment(&mut self, text: &str) {
        self.comments.push(text.replace(['\n', '\r'], " "));
    }

    /// Appends one vertex: one value per property, in order, each stored in its property's type.
    ///
    /// # Panics
    /// When `row` does not have one value per property, or an integer property's value is not
    /// an integer in its type's range (a caller's mistake, never the user's input).
    pub fn push(&mut self, row: &[f64]) {
        assert_eq!(row.len(), self.properties.len(), "one value per property");
        for (v, (name, t)) in row.iter().zip(&self.properties) {
            match t {
                PlyType::Double => self.body.extend_from_slice(&v.to_le_bytes()),
                PlyType::Float => self.body.extend_from_slice(&(*v as f32).to_le_bytes()),
                PlyType::Int => {
                    assert!(
                        v.fract() == 0.0 && *v >= f64::from(i32::MIN) && *v <= f64::from(i32::MAX),
                        "{name} = {v} is not an int"
                    );
                    self.body.extend_from_slice(&(*v as i32).to_le_bytes());
                }
                PlyType::UInt => {
                    assert!(
                        v.fract() == 0.0 && *v >= 0.0 && *v <= f64::from(u32::MAX),
                        "{name} = {v} is not a uint"
                    );
                    self.body.extend_from_slice(&(*v as u32).to_le_bytes());
                }
            }
        }
        self.count += 1;
    }

    /// The number of vertices.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether no vertex was pushed.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The header, through `end_header` and its line feed.
    pub fn header(&self) -> String {
        let mut h = String::from("ply\nformat binary_little_endian 1.0\n");
        for c in &self.comments {
            let _ = writeln!(h, "comment {c}");
        }
        let _ = writeln!(h, "element vertex {}", self.count);
        for (n, t) in &self.properties {
            let _ = writeln!(h, "property {} {n}", t.name());
        }
        h.push_str("end_header\n");
        h
    }

    /// The whole file: header, then the vertices' bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = self.header().into_bytes();
        b.extend_from_slice(&self.body);
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_and_body_bytes_by_hand() {
        let mut p = PlyVertices::new(&[
            ("x", PlyType::Double),
            ("s", PlyType::Float),
            ("i", PlyType::Int),
            ("u", PlyType::UInt),
        ]);
        p.comment("a\nb");
        p.push(&[1.0, 0.5, -2.0, 7.0]);
        let b = p.to_bytes();
        let h = "ply\nformat binary_little_endian 1.0\ncomment a b\nelement vertex 1\nproperty double x\nproperty float s\nproperty int i\nproperty uint u\nend_header\n";
        assert_eq!(&b[..h.len()], h.as_bytes());
        let body = &b[h.len()..];
        assert_eq!(&body[..8], &[0, 0, 0, 0, 0, 0, 0xf0, 0x3f]); // 1.0 as f64 LE
        assert_eq!(&body[8..12], &[0, 0, 0, 0x3f]); // 0.5 as f32 LE
        assert_eq!(&body[12..16], &[0xfe, 0xff, 0xff, 0xff]); // -2 as i32 LE
        assert_eq!(&body[16..20], &[7, 0, 0, 0]);
        assert_eq!(body.len(), 20);
        assert_eq!(p.len(), 1);
    }

    #[test]
    #[should_panic(expected = "is not an int")]
    fn a_fraction_in_an_int_column_is_a_mistake() {
        PlyVertices::new(&[("i", PlyType::Int)]).push(&[0.5]);
    }
}
