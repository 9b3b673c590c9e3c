//! Number formatting compared with the tools LIMAP writes through: a C++ iostream
//! (`std::fixed << std::setprecision(10)`, as in `LineTrack::Write`) and CPython's float
//! repr (`f"{x}"`, as in `save_txt_segments`) and `:.10f` (`save_txt_linetracks`).
//! Each test SKIPS with a printed reason when its tool is missing: a C++ compiler (`CXX`
//! or `c++`) and `PL2MAP_PYTHON` (any Python 3).

use std::io::Write;
use std::process::{Command, Stdio};

use limap::{
    AlltracksLayout, LineTrack, Segments, format_alltracks, format_segments, format_track,
};

/// Doubles of many magnitudes, signs and digit counts, plus exact ties at the 11th decimal.
fn values() -> Vec<f64> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut v = vec![
        0.0,
        -0.0,
        0.00048828125,
        -0.00146484375,
        0.5,
        1e-11,
        5e-11,
        123.25,
    ];
    for _ in 0..3000 {
        let r = next();
        let mantissa = (r >> 11) as f64 / (1u64 << 53) as f64;
        let exp = (next() % 24) as i32 - 12;
        let sign = if r & 1 == 0 { 1.0 } else { -1.0 };
        v.push(sign * mantissa * 10f64.powi(exp));
        // coordinates as detectors produce them (pixels, a few decimals)
        v.push((next() % 2_000_000) as f64 / 1024.0);
    }
    v
}

fn run(cmd: &mut Command, input: &str) -> Option<String> {
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .ok()?;
    child.stdin.take()?.write_all(input.as_bytes()).ok()?;
    let out = child.wait_with_output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8(out.stdout).ok())?
}

fn bits_input(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| format!("{}\n", v.to_bits()))
        .collect()
}

#[test]
fn track_numbers_match_cpp_iostream() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("fixed.cc");
    let exe = dir.path().join("fixed");
    std::fs::write(
        &src,
        "#include <cstdint>\n#include <cstring>\n#include <iomanip>\n#include <iostream>\n\
         int main() { std::uint64_t b; std::cout << std::fixed << std::setprecision(10);\n\
         while (std::cin >> b) { double d; std::memcpy(&d, &b, 8); std::cout << d << \" \"; }\n\
         std::cout << \"\\n\"; }\n",
    )
    .unwrap();
    let cxx = std::env::var("CXX").unwrap_or_else(|_| "c++".into());
    let built = Command::new(&cxx)
        .args(["-O1", "-o"])
        .arg(&exe)
        .arg(&src)
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !built {
        testkit::skip(format_args!("no working C++ compiler ({cxx})"));
        return;
    }
    let values = values();
    let cpp = run(&mut Command::new(&exe), &bits_input(&values)).expect("C++ program failed");
    // Our writer: six endpoint values per track, each followed by a space, as in LIMAP.
    let mut ours = String::new();
    for chunk in values.chunks(6) {
        let mut line = [[0.0; 3]; 2];
        for (slot, v) in line.iter_mut().flatten().zip(chunk) {
            *slot = *v;
        }
        let t = LineTrack {
            line,
            image_ids: vec![],
            line_ids: vec![],
            lines2d: Some(vec![]),
            extras: None,
        };
        let text = format_track(&t).unwrap();
        let first = text.lines().next().unwrap();
        let n = chunk.len();
        ours.extend(first.split(' ').take(n).map(|s| format!("{s} ")));
    }
    assert_eq!(ours.trim_end(), cpp.trim_end());
}

#[test]
fn segment_numbers_match_cpython_repr() {
    let Some(py) = testkit::python::python(&[]) else {
        return;
    };
    let values = values();
    let script = "import sys, struct\n\
                  vals = [struct.unpack('<d', int(l).to_bytes(8, 'little'))[0] for l in sys.stdin]\n\
                  print(len(vals) // 4)\n\
                  for i in range(0, len(vals) - len(vals) % 4, 4):\n\
                  \x20   print(f'{vals[i]} {vals[i+1]} {vals[i+2]} {vals[i+3]}')\n";
    let Some(expected) = run(Command::new(&py).args(["-c", script]), &bits_input(&values)) else {
        testkit::skip(format_args!("{} did not run", py.display()));
        return;
    };
    let segs = Segments::new(
        values
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect(),
    );
    assert_eq!(format_segments(&segs).unwrap(), expected);
}

#[test]
fn alltracks_numbers_match_cpython_fixed() {
    let Some(py) = testkit::python::python(&[]) else {
        return;
    };
    let values = values();
    let script = "import sys, struct\n\
                  vals = [struct.unpack('<d', int(l).to_bytes(8, 'little'))[0] for l in sys.stdin]\n\
                  print(' '.join(f'{v:.10f}' for v in vals))\n";
    let Some(expected) = run(Command::new(&py).args(["-c", script]), &bits_input(&values)) else {
        testkit::skip(format_args!("{} did not run", py.display()));
        return;
    };
    let tracks: Vec<LineTrack> = values
        .chunks_exact(6)
        .map(|c| LineTrack {
            line: [[c[0], c[1], c[2]], [c[3], c[4], c[5]]],
            image_ids: vec![],
            line_ids: vec![],
            lines2d: None,
            extras: None,
        })
        .collect();
    let text = format_alltracks(&tracks, AlltracksLayout::SingleSpace).unwrap();
    let ours: Vec<&str> = text
        .lines()
        .skip(1)
        .collect::<Vec<_>>()
        .chunks(5)
        .flat_map(|block| [block[1], block[2]])
        .flat_map(|l| l.split(' '))
        .collect();
    let n = tracks.len() * 6;
    let want: Vec<&str> = expected.split_whitespace().take(n).collect();
    assert_eq!(ours, want);
}
