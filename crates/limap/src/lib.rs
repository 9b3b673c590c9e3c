//! LIMAP line-mapping outputs: read, write and cross-check them.
//!
//! Formats (docs/formats.md section 2, LIMAP `util/io.py` and `base/linetrack.cc`):
//! - `finaltracks/track_<i>.txt` ([`parse_track`], [`format_track`]): one track, fixed
//!   notation with 10 decimals, optional auxiliary sections.
//! - `alltracks.txt` ([`parse_alltracks`], [`format_alltracks`]): the tracks seen in >= 4
//!   images, renumbered, with LIMAP's irregular spacing.
//! - `segments_<id>.txt` ([`parse_segments`], [`format_segments`]): the 2D detections of an
//!   image; a track's `line_id` is a row of this file.
//! - `image_list.txt` ([`parse_image_list`], [`format_image_list`]).
//! - LIMAP 2.0's `final_model/structures/*.bin` ([`structures`]): the 2D lines of every
//!   image and the 3D lines with their supports, read by [`limap2`] into the same
//!   [`LimapDir`] content.
//!
//! [`LimapDir`] loads a whole output folder; [`check()`] cross-checks its files and
//! [`LimapDir::load`] refuses a folder with any error. Writers produce LIMAP's bytes and
//! replace files atomically. Parsers never panic and never allocate from a count in the
//! file beyond what the remaining bytes could hold.

pub mod alltracks;
pub mod check;
pub mod dir;
pub mod error;
pub mod image_list;
pub mod io;
pub mod limap2;
mod numfmt;
mod open;
mod problem;
pub mod segments;
pub mod structures;
pub mod summary;
mod text;
pub mod track;

pub use alltracks::{
    ALLTRACKS_MIN_IMAGES, AlltracksLayout, format_alltracks, parse_alltracks, select_for_alltracks,
};
pub use check::{Check, CheckReport, CheckResult, check};
pub use dir::{InputFiles, Layout, LimapDir, LimapDirOptions, SegmentsOrigin, write_limap_dir};
pub use error::{BinaryError, LimapError, ParseError};
pub use image_list::{ImageList, format_image_list, parse_image_list};
pub use io::{
    read_alltracks, read_image_list, read_segments, read_track, read_track_allow_legacy,
    write_alltracks, write_image_list, write_segments, write_track,
};
pub use problem::{Problem, Severity};
pub use segments::{Segments, format_segments, parse_segments};
pub use structures::{
    Line3dRecord, Structure2dRecord, parse_groups3d, parse_lines3d, parse_structures2d,
    parse_wireframe3d,
};
pub use summary::Summary;
pub use track::{
    Line3d, LineTrack, Segment2d, TrackExtras, format_track, parse_track, parse_track_allow_legacy,
};
