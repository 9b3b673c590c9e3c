//! Every LIMAP text parser on the same bytes: none may panic. Whatever parses must write
//! back (the writers accept every value a parser returns, image names aside) and read back
//! to the same value, and the cross-file checks must run on it.
#![no_main]

use std::collections::BTreeMap;

use libfuzzer_sys::fuzz_target;
use limap::{
    AlltracksLayout, ImageList, check, format_alltracks, format_image_list, format_segments,
    format_track, parse_alltracks, parse_image_list, parse_segments, parse_track,
    parse_track_allow_legacy,
};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };

    let track = parse_track(text).ok();
    if let Some(t) = &track {
        // 10-decimal output is lossy once, then stable.
        let once = format_track(t).expect("a parsed track must be writable");
        let again = parse_track(&once).expect("a written track must parse");
        assert_eq!(format_track(&again).unwrap(), once);
    }
    if let Ok(t) = parse_track_allow_legacy(text) {
        let once = format_track(&t).expect("a parsed legacy track must be writable");
        let again = parse_track_allow_legacy(&once).expect("a written legacy track must parse");
        assert_eq!(again.image_ids, t.image_ids);
        assert_eq!(again.line_ids, t.line_ids);
    }

    let alltracks = parse_alltracks(text).ok();
    if let Some(all) = &alltracks {
        for layout in [AlltracksLayout::Limap, AlltracksLayout::SingleSpace] {
            let once = format_alltracks(all, layout).expect("parsed alltracks must be writable");
            let again = parse_alltracks(&once).expect("written alltracks must parse");
            assert_eq!(format_alltracks(&again, layout).unwrap(), once);
        }
    }

    let segments = parse_segments(text).ok();
    if let Some(s) = &segments {
        // Python repr round-trips exactly.
        let written = format_segments(s).expect("parsed segments must be writable");
        assert_eq!(
            &parse_segments(&written).expect("written segments must parse"),
            s
        );
    }

    let image_list = parse_image_list(text).ok();
    if let Some(list) = &image_list {
        // Names with a leading space after "id, " are refused by the writer on purpose.
        if let Ok(written) = format_image_list(list) {
            assert_eq!(
                &parse_image_list(&written).expect("written list must parse"),
                list
            );
        }
    }

    let mut seg_map = BTreeMap::new();
    if let Some(s) = segments {
        seg_map.insert(0u32, s.clone());
        seg_map.insert(1u32, s);
    }
    let tracks: Vec<_> = track
        .into_iter()
        .chain(alltracks.clone().unwrap_or_default())
        .collect();
    let report = check(
        &image_list.unwrap_or_else(ImageList::default),
        &seg_map,
        &tracks,
        alltracks.as_deref(),
    );
    let _ = report.is_ok();
});
