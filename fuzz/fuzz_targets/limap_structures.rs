//! LIMAP 2.0's binary structure files (docs/formats.md section 2, "LIMAP 2.0"): every
//! parser on the same bytes. None may panic or allocate beyond what the bytes could hold;
//! whatever parses is written back to the very same bytes (the reader keeps every field).
#![no_main]

use libfuzzer_sys::fuzz_target;
use limap::structures::{
    format_groups3d, format_lines3d, format_structures2d, format_wireframe3d, parse_groups3d,
    parse_lines3d, parse_structures2d, parse_wireframe3d,
};

fuzz_target!(|data: &[u8]| {
    if let Ok(s) = parse_structures2d(data) {
        assert_eq!(format_structures2d(&s), data);
    }
    if let Ok(l) = parse_lines3d(data) {
        assert_eq!(format_lines3d(&l), data);
    }
    if let Ok(g) = parse_groups3d(data) {
        assert_eq!(format_groups3d(&g), data);
    }
    if let Ok(w) = parse_wireframe3d(data) {
        assert_eq!(format_wireframe3d(&w), data);
    }
});
