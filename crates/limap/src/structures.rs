//! LIMAP 2.0's binary structure files, `final_model/structures/*.bin` (docs/formats.md,
//! section 2, "LIMAP 2.0").
//!
//! Every value is little-endian; a count is a u64 unless said otherwise. Image ids and 2D
//! indices are u32, 3D ids u64 (COLMAP's `image_t`, `point2D_t`, `point3D_t`).
//! ```text
//! structures2d.bin  u64 N, N x { u32 image_id, u32 num_points,
//!                       u64 L, L x { f64 x1 y1 x2 y2 score, u64 line3D_id },
//!                       u64 G, G x group2d, u64 E, E x { u32 point, u32 line, f64 w } }
//!   group2d         i32 type, u64 P, P x { u32 idx, f64 w }, u64 Q, Q x { u32 idx, f64 w },
//!                   u64 group3D_id
//! lines3D.bin       u64 N, N x { u64 line3D_id, f64 sx sy sz ex ey ez,
//!                       u64 T, T x { u32 image_id, u32 line index }, f64 uncertainty }
//! groups3D.bin      u64 N, N x { u64 group3D_id, i32 type, u64 P, P x { u64 idx, f64 w },
//!                       u64 Q, Q x { u64 idx, f64 w }, u64 T, T x { u32, u32 },
//!                       u64 K, K x f64 param }
//! wireframe3D.bin   u64 N, N x { u64 point3D_id, u64 line3D_id, f64 w }
//! ```
//! The files carry no version number and no magic bytes: a file of another layout shows
//! as a truncated record, an unknown group type or bytes left after the last record, and
//! each of these is refused. The line index of a track element is the row of the line in
//! its image's `structures2d.bin` record (the same row as in `segments_<id>.txt`).
//!
//! Parsers never panic and never allocate from a count beyond what the remaining bytes
//! could hold.

use serde::Serialize;

use crate::error::BinaryError;
use crate::track::{Line3d, Segment2d};

/// The id LIMAP (COLMAP's `kInvalidPoint3DId`) gives a 2D line without a 3D line.
pub const INVALID_LINE3D_ID: u64 = u64::MAX;

/// LIMAP's group types (`GroupType`: INVALID = -1, VP, PLANE, SPHERE, CYLINDER,
/// ELLIPSOID, CUBOID, CONE); any other value is refused.
pub const GROUP_TYPES: [(i32, &str); 8] = [
    (-1, "INVALID"),
    (0, "VP"),
    (1, "PLANE"),
    (2, "SPHERE"),
    (3, "CYLINDER"),
    (4, "ELLIPSOID"),
    (5, "CUBOID"),
    (6, "CONE"),
];

pub const STRUCTURES2D_FILE: &str = "structures2d.bin";
pub const LINES3D_FILE: &str = "lines3D.bin";
pub const GROUPS3D_FILE: &str = "groups3D.bin";
pub const WIREFRAME3D_FILE: &str = "wireframe3D.bin";

/// One 2D line of an image (LIMAP `Line2d`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Line2dRecord {
    pub segment: Segment2d,
    pub score: f64,
    /// The 3D line this detection supports, or [`INVALID_LINE3D_ID`].
    pub line3d_id: u64,
}

/// A 2D group (vanishing point, plane, ...) of an image and its members.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Group2dRecord {
    pub group_type: i32,
    /// (keypoint index, weight).
    pub points: Vec<(u32, f64)>,
    /// (line row, weight).
    pub lines: Vec<(u32, f64)>,
    pub group3d_id: u64,
}

/// Everything LIMAP 2.0 keeps of one image (`Structure2d`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Structure2dRecord {
    pub image_id: u32,
    /// Number of keypoints of the image in the COLMAP model.
    pub num_points: u32,
    pub lines: Vec<Line2dRecord>,
    pub groups: Vec<Group2dRecord>,
    /// 2D wireframe edges: (keypoint index, line row, weight).
    pub wireframe: Vec<(u32, u32, f64)>,
}

/// A triangulated 3D line and its supports (LIMAP `Line3d`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Line3dRecord {
    pub id: u64,
    pub line: Line3d,
    /// (image id, line row in that image's structure), in file order.
    pub track: Vec<(u32, u32)>,
    pub uncertainty: f64,
}

/// A triangulated 3D group (LIMAP `Group3d`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Group3dRecord {
    pub id: u64,
    pub group_type: i32,
    /// (3D point id, weight).
    pub points: Vec<(u64, f64)>,
    /// (3D line id, weight).
    pub lines: Vec<(u64, f64)>,
    pub track: Vec<(u32, u32)>,
    pub params: Vec<f64>,
}

/// An edge of the 3D wireframe: a 3D point attached to a 3D line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WireframeEdge {
    pub point3d_id: u64,
    pub line3d_id: u64,
    pub weight: f64,
}

struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    record: Option<String>,
}

type Res<T> = Result<T, BinaryError>;

impl<'a> Cursor<'a> {
    fn new(buf: &'a [u8]) -> Self {
        Cursor {
            buf,
            pos: 0,
            record: None,
        }
    }

    fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    fn err(&self, offset: usize, problem: impl Into<String>) -> BinaryError {
        BinaryError {
            offset,
            record: self.record.clone(),
            problem: problem.into(),
        }
    }

    fn take<const N: usize>(&mut self, what: &str) -> Res<[u8; N]> {
        let remaining = self.remaining();
        if N > remaining {
            return Err(self.err(
                self.pos,
                format!(
                    "expected {what} ({N} bytes), but the file ends after {remaining} byte(s) \
                     (truncated)"
                ),
            ));
        }
        let mut a = [0u8; N];
        a.copy_from_slice(&self.buf[self.pos..self.pos + N]);
        self.pos += N;
        Ok(a)
    }

    fn u32(&mut self, what: &str) -> Res<u32> {
        Ok(u32::from_le_bytes(self.take(what)?))
    }

    fn i32(&mut self, what: &str) -> Res<i32> {
        Ok(i32::from_le_bytes(self.take(what)?))
    }

    fn u64(&mut self, what: &str) -> Res<u64> {
        Ok(u64::from_le_bytes(self.take(what)?))
    }

    fn f64(&mut self, what: &str) -> Res<f64> {
        Ok(f64::from_le_bytes(self.take(what)?))
    }

    /// A finite coordinate.
    fn coord(&mut self, what: &str) -> Res<f64> {
        let at = self.pos;
        let v = self.f64(what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(at, format!("expected a finite {what}, found {v}")))
        }
    }

    /// A u64 count of items of at least `min_each` bytes, checked against what remains so
    /// that no allocation is sized by an unchecked count.
    fn count(&mut self, what: &str, min_each: usize) -> Res<usize> {
        let at = self.pos;
        let count = self.u64(&format!("number of {what}"))?;
        let need = u128::from(count) * min_each as u128;
        let remaining = self.remaining();
        if need > remaining as u128 {
            return Err(self.err(
                at,
                format!(
                    "{count} {what} need at least {need} bytes, but only {remaining} remain \
                     (truncated, or not a LIMAP 2.0 file)"
                ),
            ));
        }
        Ok(count as usize)
    }

    fn group_type(&mut self) -> Res<i32> {
        let at = self.pos;
        let t = self.i32("group type")?;
        if GROUP_TYPES.iter().any(|(v, _)| *v == t) {
            Ok(t)
        } else {
            Err(self.err(
                at,
                format!(
                    "unknown group type {t} (LIMAP 2.0 knows {})",
                    GROUP_TYPES
                        .iter()
                        .map(|(v, n)| format!("{v} {n}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ))
        }
    }

    /// A u64 count (checked as [`Self::count`]) followed by that many items, each read
    /// by `item`.
    fn list<T>(
        &mut self,
        what: &str,
        min_each: usize,
        mut item: impl FnMut(&mut Self) -> Res<T>,
    ) -> Res<Vec<T>> {
        let n = self.count(what, min_each)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            out.push(item(self)?);
        }
        Ok(out)
    }

    /// A whole file of records: a u64 count (checked as [`Self::count`]), then the
    /// records, each read by `item` (given its index) with errors naming `record <k>`,
    /// and nothing after the last (`what` names one record in that error).
    fn records<T>(
        &mut self,
        plural: &str,
        what: &str,
        min_each: usize,
        mut item: impl FnMut(&mut Self, usize) -> Res<T>,
    ) -> Res<Vec<T>> {
        let n = self.count(plural, min_each)?;
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            self.record = Some(format!("record {k}"));
            out.push(item(self, k)?);
        }
        self.finish(what)?;
        Ok(out)
    }

    fn track(&mut self) -> Res<Vec<(u32, u32)>> {
        self.list("track elements", 8, |c| {
            Ok((
                c.u32("image id of a track element")?,
                c.u32("line index of a track element")?,
            ))
        })
    }

    fn finish(&mut self, what: &str) -> Res<()> {
        self.record = None;
        if self.remaining() == 0 {
            Ok(())
        } else {
            Err(self.err(
                self.pos,
                format!(
                    "{} byte(s) after the last {what} record (a different version of the \
                     format, or a corrupted count)",
                    self.remaining()
                ),
            ))
        }
    }
}

/// Parses `structures2d.bin`. Image ids must be distinct.
pub fn parse_structures2d(bytes: &[u8]) -> Result<Vec<Structure2dRecord>, BinaryError> {
    let mut c = Cursor::new(bytes);
    let mut seen = std::collections::HashSet::new();
    c.records("images", "image", 4 + 4 + 3 * 8, |c, k| {
        let at = c.pos;
        let image_id = c.u32("image id")?;
        c.record = Some(format!("record {k} (image {image_id})"));
        if !seen.insert(image_id) {
            return Err(c.err(at, format!("image {image_id} has a second record")));
        }
        let num_points = c.u32("number of keypoints")?;
        let lines = c.list("2D lines", 48, |c| {
            let segment = [
                c.coord("x1")?,
                c.coord("y1")?,
                c.coord("x2")?,
                c.coord("y2")?,
            ];
            Ok(Line2dRecord {
                segment,
                score: c.f64("score")?,
                line3d_id: c.u64("3D line id of a 2D line")?,
            })
        })?;
        let groups = c.list("2D groups", 4 + 8 + 8 + 8, |c| {
            Ok(Group2dRecord {
                group_type: c.group_type()?,
                points: c.list("group points", 12, |c| {
                    Ok((c.u32("keypoint index")?, c.f64("weight")?))
                })?,
                lines: c.list("group lines", 12, |c| {
                    Ok((c.u32("line index")?, c.f64("weight")?))
                })?,
                group3d_id: c.u64("3D group id")?,
            })
        })?;
        let wireframe = c.list("2D wireframe edges", 16, |c| {
            Ok((
                c.u32("keypoint index")?,
                c.u32("line index")?,
                c.f64("weight")?,
            ))
        })?;
        Ok(Structure2dRecord {
            image_id,
            num_points,
            lines,
            groups,
            wireframe,
        })
    })
}

/// Parses `lines3D.bin`. Line ids must be distinct and endpoints finite.
pub fn parse_lines3d(bytes: &[u8]) -> Result<Vec<Line3dRecord>, BinaryError> {
    let mut c = Cursor::new(bytes);
    let mut seen = std::collections::HashSet::new();
    c.records("3D lines", "3D line", 8 + 48 + 8 + 8, |c, k| {
        let at = c.pos;
        let id = c.u64("3D line id")?;
        c.record = Some(format!("record {k} (3D line {id})"));
        if !seen.insert(id) {
            return Err(c.err(at, format!("3D line {id} has a second record")));
        }
        let mut line = [[0.0; 3]; 2];
        for (p, name) in line.iter_mut().zip(["start", "end"]) {
            for (v, axis) in p.iter_mut().zip(["x", "y", "z"]) {
                *v = c.coord(&format!("{name} {axis}"))?;
            }
        }
        let track = c.track()?;
        let uncertainty = c.f64("uncertainty")?;
        Ok(Line3dRecord {
            id,
            line,
            track,
            uncertainty,
        })
    })
}

/// Parses `groups3D.bin`.
pub fn parse_groups3d(bytes: &[u8]) -> Result<Vec<Group3dRecord>, BinaryError> {
    let mut c = Cursor::new(bytes);
    c.records("3D groups", "3D group", 8 + 4 + 4 * 8, |c, k| {
        let id = c.u64("3D group id")?;
        c.record = Some(format!("record {k} (3D group {id})"));
        let group_type = c.group_type()?;
        let points = c.list("group points", 16, |c| {
            Ok((c.u64("3D point id")?, c.f64("weight")?))
        })?;
        let lines = c.list("group lines", 16, |c| {
            Ok((c.u64("3D line id")?, c.f64("weight")?))
        })?;
        let track = c.track()?;
        let params = c.list("group parameters", 8, |c| c.f64("group parameter"))?;
        Ok(Group3dRecord {
            id,
            group_type,
            points,
            lines,
            track,
            params,
        })
    })
}

/// Parses `wireframe3D.bin`.
pub fn parse_wireframe3d(bytes: &[u8]) -> Result<Vec<WireframeEdge>, BinaryError> {
    let mut c = Cursor::new(bytes);
    c.records("wireframe edges", "wireframe edge", 24, |c, _| {
        Ok(WireframeEdge {
            point3d_id: c.u64("3D point id")?,
            line3d_id: c.u64("3D line id")?,
            weight: c.f64("weight")?,
        })
    })
}

fn put_u32(b: &mut Vec<u8>, v: u32) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_u64(b: &mut Vec<u8>, v: u64) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_f64(b: &mut Vec<u8>, v: f64) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_len(b: &mut Vec<u8>, n: usize) {
    put_u64(b, n as u64);
}

/// The bytes LIMAP 2.0 writes for these records (in the given order; LIMAP sorts by image
/// id). For tests and fixtures.
pub fn format_structures2d(records: &[Structure2dRecord]) -> Vec<u8> {
    let mut b = Vec::new();
    put_len(&mut b, records.len());
    for r in records {
        put_u32(&mut b, r.image_id);
        put_u32(&mut b, r.num_points);
        put_len(&mut b, r.lines.len());
        for l in &r.lines {
            for v in l.segment {
                put_f64(&mut b, v);
            }
            put_f64(&mut b, l.score);
            put_u64(&mut b, l.line3d_id);
        }
        put_len(&mut b, r.groups.len());
        for g in &r.groups {
            b.extend_from_slice(&g.group_type.to_le_bytes());
            for members in [&g.points, &g.lines] {
                put_len(&mut b, members.len());
                for (i, w) in members {
                    put_u32(&mut b, *i);
                    put_f64(&mut b, *w);
                }
            }
            put_u64(&mut b, g.group3d_id);
        }
        put_len(&mut b, r.wireframe.len());
        for (p, l, w) in &r.wireframe {
            put_u32(&mut b, *p);
            put_u32(&mut b, *l);
            put_f64(&mut b, *w);
        }
    }
    b
}

fn put_track(b: &mut Vec<u8>, track: &[(u32, u32)]) {
    put_len(b, track.len());
    for (i, l) in track {
        put_u32(b, *i);
        put_u32(b, *l);
    }
}

/// The bytes LIMAP 2.0 writes for these 3D lines (in the given order; LIMAP sorts by id).
pub fn format_lines3d(records: &[Line3dRecord]) -> Vec<u8> {
    let mut b = Vec::new();
    put_len(&mut b, records.len());
    for r in records {
        put_u64(&mut b, r.id);
        for p in r.line {
            for v in p {
                put_f64(&mut b, v);
            }
        }
        put_track(&mut b, &r.track);
        put_f64(&mut b, r.uncertainty);
    }
    b
}

/// The bytes LIMAP 2.0 writes for these 3D groups.
pub fn format_groups3d(records: &[Group3dRecord]) -> Vec<u8> {
    let mut b = Vec::new();
    put_len(&mut b, records.len());
    for r in records {
        put_u64(&mut b, r.id);
        b.extend_from_slice(&r.group_type.to_le_bytes());
        for members in [&r.points, &r.lines] {
            put_len(&mut b, members.len());
            for (i, w) in members {
                put_u64(&mut b, *i);
                put_f64(&mut b, *w);
            }
        }
        put_track(&mut b, &r.track);
        put_len(&mut b, r.params.len());
        for v in &r.params {
            put_f64(&mut b, *v);
        }
    }
    b
}

/// The bytes LIMAP 2.0 writes for a 3D wireframe.
pub fn format_wireframe3d(edges: &[WireframeEdge]) -> Vec<u8> {
    let mut b = Vec::new();
    put_len(&mut b, edges.len());
    for e in edges {
        put_u64(&mut b, e.point3d_id);
        put_u64(&mut b, e.line3d_id);
        put_f64(&mut b, e.weight);
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn structures() -> Vec<Structure2dRecord> {
        vec![
            Structure2dRecord {
                image_id: 1,
                num_points: 3,
                lines: vec![
                    Line2dRecord {
                        segment: [1.0, 2.0, 3.0, 4.0],
                        score: 0.5,
                        line3d_id: 7,
                    },
                    Line2dRecord {
                        segment: [5.0, 6.0, 7.0, 8.0],
                        score: 0.0,
                        line3d_id: INVALID_LINE3D_ID,
                    },
                ],
                groups: vec![Group2dRecord {
                    group_type: 0,
                    points: vec![(2, 1.0)],
                    lines: vec![(0, 0.5), (1, 0.25)],
                    group3d_id: 4,
                }],
                wireframe: vec![(0, 1, 0.75)],
            },
            Structure2dRecord {
                image_id: 5,
                num_points: 0,
                lines: vec![],
                groups: vec![],
                wireframe: vec![],
            },
        ]
    }

    fn lines() -> Vec<Line3dRecord> {
        vec![Line3dRecord {
            id: 7,
            line: [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
            track: vec![(1, 0), (5, 3)],
            uncertainty: 0.01,
        }]
    }

    #[test]
    fn round_trips() {
        let s = structures();
        assert_eq!(parse_structures2d(&format_structures2d(&s)).unwrap(), s);
        let l = lines();
        assert_eq!(parse_lines3d(&format_lines3d(&l)).unwrap(), l);
        let g = vec![Group3dRecord {
            id: 4,
            group_type: 1,
            points: vec![(9, 1.0)],
            lines: vec![(7, 1.0)],
            track: vec![(1, 0)],
            params: vec![0.0, 0.0, 1.0, 2.0],
        }];
        assert_eq!(parse_groups3d(&format_groups3d(&g)).unwrap(), g);
        let w = vec![WireframeEdge {
            point3d_id: 9,
            line3d_id: 7,
            weight: 1.0,
        }];
        assert_eq!(parse_wireframe3d(&format_wireframe3d(&w)).unwrap(), w);
        for empty in [
            format_structures2d(&[]),
            format_lines3d(&[]),
            format_groups3d(&[]),
            format_wireframe3d(&[]),
        ] {
            assert_eq!(empty, 0u64.to_le_bytes());
        }
    }

    #[test]
    fn every_truncation_is_refused_with_its_record() {
        let bytes = format_structures2d(&structures());
        for len in 0..bytes.len() {
            let e = parse_structures2d(&bytes[..len]).unwrap_err();
            assert!(e.offset <= len, "{len}: {e}");
            // Past the header count, every error names its record.
            assert_eq!(e.record.is_some(), e.offset >= 8, "{len}: {e}");
        }
        let bytes = format_lines3d(&lines());
        for len in 0..bytes.len() {
            let e = parse_lines3d(&bytes[..len]).unwrap_err().to_string();
            assert!(e.contains("truncated"), "{len}: {e}");
        }
        let e = parse_lines3d(&bytes[..bytes.len() - 3]).unwrap_err();
        assert_eq!(e.record.as_deref(), Some("record 0 (3D line 7)"));
    }

    #[test]
    fn huge_counts_allocate_nothing() {
        let mut b = u64::MAX.to_le_bytes().to_vec();
        b.extend_from_slice(&[0; 64]);
        let e = parse_lines3d(&b).unwrap_err().to_string();
        assert!(e.contains("need at least"), "{e}");
        let e = parse_structures2d(&b).unwrap_err().to_string();
        assert!(e.contains("need at least"), "{e}");
    }

    #[test]
    fn unknown_group_types_are_refused() {
        let mut s = structures();
        s[0].groups[0].group_type = 7;
        let e = parse_structures2d(&format_structures2d(&s))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("record 0 (image 1)") && e.contains("unknown group type 7"),
            "{e}"
        );
        let g = vec![Group3dRecord {
            id: 2,
            group_type: -2,
            points: vec![],
            lines: vec![],
            track: vec![],
            params: vec![],
        }];
        let e = parse_groups3d(&format_groups3d(&g))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("3D group 2") && e.contains("unknown group type -2"),
            "{e}"
        );
    }

    #[test]
    fn trailing_bytes_and_duplicates_are_refused() {
        let mut b = format_lines3d(&lines());
        b.push(0);
        let e = parse_lines3d(&b).unwrap_err().to_string();
        assert!(e.contains("1 byte(s) after the last 3D line record"), "{e}");
        let mut l = lines();
        l.push(l[0].clone());
        let e = parse_lines3d(&format_lines3d(&l)).unwrap_err().to_string();
        assert!(e.contains("3D line 7 has a second record"), "{e}");
        let mut s = structures();
        s[1].image_id = 1;
        let e = parse_structures2d(&format_structures2d(&s))
            .unwrap_err()
            .to_string();
        assert!(e.contains("image 1 has a second record"), "{e}");
    }

    /// A seeded stand-in for the fuzz target (fuzz/fuzz_targets/limap_structures.rs):
    /// valid files with random bytes overwritten never panic, and whatever still parses
    /// writes back to the same bytes.
    #[test]
    fn mutated_files_never_panic_and_round_trip() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let g = format_groups3d(&[Group3dRecord {
            id: 4,
            group_type: 1,
            points: vec![(9, 1.0)],
            lines: vec![(7, 1.0)],
            track: vec![(1, 0)],
            params: vec![0.0, 0.0, 1.0, 2.0],
        }]);
        let w = format_wireframe3d(&[WireframeEdge {
            point3d_id: 1,
            line3d_id: 2,
            weight: 0.5,
        }]);
        for original in [
            format_structures2d(&structures()),
            format_lines3d(&lines()),
            g,
            w,
        ] {
            for _ in 0..2000 {
                let mut b = original.clone();
                for _ in 0..1 + next() % 3 {
                    let i = (next() % b.len() as u64) as usize;
                    b[i] = next() as u8;
                }
                let cut = b.len() - (next() % 4) as usize;
                let b = &b[..cut];
                if let Ok(r) = parse_structures2d(b) {
                    assert_eq!(format_structures2d(&r), b);
                }
                if let Ok(r) = parse_lines3d(b) {
                    assert_eq!(format_lines3d(&r), b);
                }
                if let Ok(r) = parse_groups3d(b) {
                    assert_eq!(format_groups3d(&r), b);
                }
                if let Ok(r) = parse_wireframe3d(b) {
                    assert_eq!(format_wireframe3d(&r), b);
                }
            }
        }
    }

    #[test]
    fn non_finite_endpoints_are_refused() {
        let mut l = lines();
        l[0].line[1][2] = f64::NAN;
        let e = parse_lines3d(&format_lines3d(&l)).unwrap_err().to_string();
        assert!(e.contains("finite end z"), "{e}");
    }
}
