//! Our `%.17g` against Python's (correctly rounded, like glibc's printf that COLMAP's
//! `<<` uses). Needs PL2MAP_PYTHON; skipped without it.

use std::process::Command;

#[test]
fn g17_matches_python_printf() {
    let Some(python) = testkit::python::python(&[]) else {
        return;
    };
    let mut values = Vec::new();
    let mut s = 0x2545_F491_4F6C_DD1D_u64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    for i in 0..30_000u64 {
        let r = next();
        let x = match i % 3 {
            // Any finite double.
            0 => f64::from_bits(r),
            // Short decimals as people and older COLMAP write them (6-digit values).
            1 => (r % 2_000_000) as f64 / 10f64.powi((r >> 40) as i32 % 9) - 1000.0,
            // Values of every magnitude around the %g exponent switches.
            _ => (r as f64 / u64::MAX as f64) * 10f64.powi((r >> 50) as i32 % 44 - 22),
        };
        if x.is_finite() {
            values.push(x);
        }
    }
    let mut input = String::new();
    for x in &values {
        for b in x.to_le_bytes() {
            input.push_str(&format!("{b:02x}"));
        }
        input.push('\n');
    }
    let out = testkit::python::run_with_input(
        Command::new(&python).args(["-c", "import sys,struct\nfor l in sys.stdin: print('%.17g' % struct.unpack('<d', bytes.fromhex(l.strip()))[0])"]),
        input.into_bytes(),
    );
    let text = String::from_utf8(out).unwrap();
    let theirs: Vec<&str> = text.lines().collect();
    assert_eq!(theirs.len(), values.len());
    for (x, t) in values.iter().zip(theirs) {
        let mut ours = String::new();
        colmap::text::push_g17(&mut ours, *x);
        assert_eq!(ours, t, "bits {:#x}", x.to_bits());
    }
}
