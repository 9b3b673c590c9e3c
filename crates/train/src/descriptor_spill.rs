//! The descriptors of the frames past the memory budget, in one file under the train
//! folder, so that a scene of any size describes each frame once per run instead of
//! once per use (docs/performance.md, "A real scene's size").
//!
//! A sample reads only its own rows (its keypoints' and segments', a few KiB) with
//! positioned reads: the file stays in the page cache, which the kernel may drop under
//! memory pressure, instead of in the process's memory. Values are the f32 rows the
//! front-end returned, bit for bit, so where a frame's rows come from (memory, this file
//! or the front-end) changes the speed of a run, never its samples.
//!
//! Layout (little-endian): `MAGIC`, the 32-byte key, D and T (u32 each), then each
//! frame's point rows (N x D f32) and line rows (M x T x D f32), then the index (frame id
//! u64, offset u64, N u32, M u32 per frame), its entry count (u64) and the index's offset
//! (u64). Written under a temporary name and renamed once complete: a file under the
//! final name is whole.

use crate::error::{TrainError, io_err};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// The file's name in the train folder (removed when a run finishes).
pub const SPILL_FILE: &str = "descriptors.spill";

/// The rows of one sample: (points, line samples).
type SampleRows = (Vec<f32>, Vec<f32>);

const MAGIC: &[u8; 8] = b"PL2MDSP1";
const HEADER_BYTES: u64 = 8 + 32 + 8;
const ENTRY_BYTES: usize = 24;

/// Where a frame's rows are in the file.
#[derive(Clone, Copy, Debug)]
struct Entry {
    offset: u64,
    points: u32,
    segments: u32,
}

/// An open, complete spill file.
#[derive(Debug)]
pub struct SpillFile {
    path: PathBuf,
    file: File,
    index: HashMap<u64, Entry>,
    dim: usize,
    samples_per_line: usize,
}

impl SpillFile {
    /// Opens the file at `path` if it is complete and was written for `key`, D and T;
    /// None when it is absent or another run's (the caller rebuilds it).
    pub fn open(
        path: &Path,
        key: &[u8; 32],
        dim: usize,
        samples_per_line: usize,
    ) -> Result<Option<SpillFile>, TrainError> {
        let mut file = match File::open(path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(io_err(path)(e).into()),
        };
        let len = file.metadata().map_err(io_err(path))?.len();
        let mut header = [0u8; HEADER_BYTES as usize];
        if len < HEADER_BYTES + 16 || file.read_exact(&mut header).is_err() {
            return Ok(None);
        }
        let same = &header[..8] == MAGIC
            && &header[8..40] == key
            && u32_at(&header, 40) as usize == dim
            && u32_at(&header, 44) as usize == samples_per_line;
        if !same {
            return Ok(None);
        }
        let mut tail = [0u8; 16];
        file.read_exact_at(&mut tail, len - 16)
            .map_err(io_err(path))?;
        let count = u64_at(&tail, 0);
        let index_at = u64_at(&tail, 8);
        let index_bytes = count.checked_mul(ENTRY_BYTES as u64);
        if index_bytes.and_then(|b| b.checked_add(index_at + 16)) != Some(len)
            || index_at < HEADER_BYTES
        {
            return Ok(None);
        }
        let mut raw = vec![0u8; (count as usize) * ENTRY_BYTES];
        file.seek(SeekFrom::Start(index_at)).map_err(io_err(path))?;
        file.read_exact(&mut raw).map_err(io_err(path))?;
        let index = raw
            .chunks_exact(ENTRY_BYTES)
            .map(|e| {
                (
                    u64_at(e, 0),
                    Entry {
                        offset: u64_at(e, 8),
                        points: u32_at(e, 16),
                        segments: u32_at(e, 20),
                    },
                )
            })
            .collect();
        Ok(Some(SpillFile {
            path: path.to_path_buf(),
            file,
            index,
            dim,
            samples_per_line,
        }))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn contains(&self, frame_id: u64) -> bool {
        self.index.contains_key(&frame_id)
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The rows of the frame's keypoints `points` and segments `segments` (indices into
    /// the frame's arrays), in that order; None if the frame is not in the file.
    pub fn rows(
        &self,
        frame_id: u64,
        points: &[usize],
        segments: &[usize],
    ) -> Option<Result<SampleRows, TrainError>> {
        let e = *self.index.get(&frame_id)?;
        Some(self.read_rows(frame_id, e, points, segments))
    }

    fn read_rows(
        &self,
        frame_id: u64,
        e: Entry,
        points: &[usize],
        segments: &[usize],
    ) -> Result<(Vec<f32>, Vec<f32>), TrainError> {
        let d = self.dim;
        let td = self.samples_per_line * d;
        let lines_at = e.offset + 4 * (e.points as u64) * d as u64;
        let read = |at: u64, count: usize, index: &[usize], limit: u32| {
            let mut out = vec![0f32; index.len() * count];
            let mut bytes = vec![0u8; count * 4];
            for (row, &i) in out.chunks_exact_mut(count).zip(index) {
                if i >= limit as usize {
                    return Err(self.damaged(frame_id, "a row past the frame's"));
                }
                let offset = at + 4 * (i * count) as u64;
                self.file
                    .read_exact_at(&mut bytes, offset)
                    .map_err(io_err(&self.path))?;
                for (v, b) in row.iter_mut().zip(bytes.chunks_exact(4)) {
                    *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
            Ok(out)
        };
        Ok((
            read(e.offset, d, points, e.points)?,
            read(lines_at, td, segments, e.segments)?,
        ))
    }

    fn damaged(&self, frame_id: u64, what: &str) -> TrainError {
        TrainError::Config(format!(
            "descriptor file {}: frame {frame_id}: {what} (delete the file; the next run rebuilds it)",
            self.path.display()
        ))
    }

    /// Removes the file (a finished run's).
    pub fn remove(self) -> Result<(), TrainError> {
        let path = self.path.clone();
        drop(self.file);
        std::fs::remove_file(&path).map_err(io_err(&path))?;
        Ok(())
    }
}

/// Writes a spill file under a temporary name; [`SpillWriter::finish`] renames it.
pub struct SpillWriter {
    path: PathBuf,
    tmp: PathBuf,
    out: BufWriter<File>,
    at: u64,
    index: Vec<(u64, Entry)>,
    dim: usize,
    samples_per_line: usize,
}

impl SpillWriter {
    pub fn create(
        path: &Path,
        key: &[u8; 32],
        dim: usize,
        samples_per_line: usize,
    ) -> Result<SpillWriter, TrainError> {
        let tmp = path.with_extension("spill.tmp");
        let file = File::create(&tmp).map_err(io_err(&tmp))?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        let mut header = Vec::with_capacity(HEADER_BYTES as usize);
        header.extend_from_slice(MAGIC);
        header.extend_from_slice(key);
        header.extend_from_slice(&(dim as u32).to_le_bytes());
        header.extend_from_slice(&(samples_per_line as u32).to_le_bytes());
        out.write_all(&header).map_err(io_err(&tmp))?;
        Ok(SpillWriter {
            path: path.to_path_buf(),
            tmp,
            out,
            at: HEADER_BYTES,
            index: Vec::new(),
            dim,
            samples_per_line,
        })
    }

    /// Appends one frame's rows (`points`: N x D, `lines`: M x T x D).
    pub fn push(&mut self, frame_id: u64, points: &[f32], lines: &[f32]) -> Result<(), TrainError> {
        let (d, td) = (self.dim, self.dim * self.samples_per_line);
        if !points.len().is_multiple_of(d) || !lines.len().is_multiple_of(td) {
            return Err(TrainError::Config(format!(
                "frame {frame_id}: descriptor rows of the wrong width for D = {d}"
            )));
        }
        let mut bytes = Vec::with_capacity(4 * (points.len() + lines.len()));
        for v in points.iter().chain(lines) {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        self.out.write_all(&bytes).map_err(io_err(&self.tmp))?;
        self.index.push((
            frame_id,
            Entry {
                offset: self.at,
                points: (points.len() / d) as u32,
                segments: (lines.len() / td) as u32,
            },
        ));
        self.at += bytes.len() as u64;
        Ok(())
    }

    /// Writes the index, syncs and renames the file to its final name.
    pub fn finish(mut self) -> Result<PathBuf, TrainError> {
        let mut tail = Vec::with_capacity(self.index.len() * ENTRY_BYTES + 16);
        for (id, e) in &self.index {
            tail.extend_from_slice(&id.to_le_bytes());
            tail.extend_from_slice(&e.offset.to_le_bytes());
            tail.extend_from_slice(&e.points.to_le_bytes());
            tail.extend_from_slice(&e.segments.to_le_bytes());
        }
        tail.extend_from_slice(&(self.index.len() as u64).to_le_bytes());
        tail.extend_from_slice(&self.at.to_le_bytes());
        self.out.write_all(&tail).map_err(io_err(&self.tmp))?;
        let file = self
            .out
            .into_inner()
            .map_err(|e| io_err(&self.tmp)(e.into_error()))?;
        file.sync_all().map_err(io_err(&self.tmp))?;
        std::fs::rename(&self.tmp, &self.path).map_err(io_err(&self.path))?;
        Ok(self.path)
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[at..at + 8]);
    u64::from_le_bytes(a)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows come back bit for bit, for any subset; another key, D or T, or a cut-short
    /// file is not taken for this run's.
    #[test]
    fn rows_round_trip_and_foreign_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("descriptors.spill");
        let key = [7u8; 32];
        let (d, t) = (4, 2);
        let frame = |id: u64, n: usize, m: usize| -> (Vec<f32>, Vec<f32>) {
            let p = (0..n * d)
                .map(|i| (id * 1000 + i as u64) as f32 / 7.0)
                .collect();
            let l = (0..m * t * d)
                .map(|i| -((id * 1000 + i as u64) as f32) / 3.0)
                .collect();
            (p, l)
        };
        let mut w = SpillWriter::create(&path, &key, d, t).unwrap();
        for id in [5u64, 2, 9] {
            let (p, l) = frame(id, 3 + id as usize, 2);
            w.push(id, &p, &l).unwrap();
        }
        assert!(!path.exists(), "nothing under the final name before finish");
        w.finish().unwrap();
        let s = SpillFile::open(&path, &key, d, t).unwrap().unwrap();
        assert_eq!(s.len(), 3);
        for id in [5u64, 2, 9] {
            let (p, l) = frame(id, 3 + id as usize, 2);
            let (rp, rl) = s.rows(id, &[0, 2], &[1]).unwrap().unwrap();
            assert_eq!(rp, [&p[0..d], &p[2 * d..3 * d]].concat());
            assert_eq!(rl, l[t * d..2 * t * d].to_vec());
        }
        assert!(s.rows(4, &[0], &[]).is_none());
        assert!(s.rows(2, &[40], &[]).unwrap().is_err());
        assert!(SpillFile::open(&path, &[8u8; 32], d, t).unwrap().is_none());
        assert!(SpillFile::open(&path, &key, d + 1, t).unwrap().is_none());
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        assert!(SpillFile::open(&path, &key, d, t).unwrap().is_none());
        assert!(
            SpillFile::open(&dir.path().join("none"), &key, d, t)
                .unwrap()
                .is_none()
        );
    }
}
