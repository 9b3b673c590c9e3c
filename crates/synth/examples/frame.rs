//! Renders frames of the synthetic dataset to PNG files and prints timings.
//! Usage: cargo run --release -p synth --example frame -- OUT_DIR [SEED] [FRAME...]

use std::time::Instant;
use synth::SynthDataset;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = std::path::PathBuf::from(args.get(1).map(String::as_str).unwrap_or("/tmp/synth"));
    let seed: u64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(0);
    let frames: Vec<usize> = if args.len() > 3 {
        args[3..]
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![0]
    };
    std::fs::create_dir_all(&out)?;
    let t = Instant::now();
    let ds = SynthDataset::new(300, seed, false)?;
    println!(
        "scene: {} quads, {} edges, {} objects, built in {:.3} s",
        ds.scene.quads().len(),
        ds.scene.edges().len(),
        ds.scene.objects().len(),
        t.elapsed().as_secs_f64()
    );
    let texels: usize = (0..ds.scene.quads().len() as u32)
        .map(|q| {
            let (w, h) = ds.scene.texture(q).map(|t| t.size()).unwrap_or((0, 0));
            w * h
        })
        .sum();
    println!("texels (base levels): {:.1} M", texels as f64 / 1e6);
    // Two overviews from high corners, for judging the whole room.
    for (k, (c, yaw)) in [
        ([0.35, 0.35, 2.1], 0.6f64),
        ([3.65, 2.65, 2.1], 0.6 + std::f64::consts::PI),
    ]
    .iter()
    .enumerate()
    {
        let r = synth::trajectory::look_rotation(*yaw, -0.45, 0.0);
        let pose = synth::trajectory::pose_from_centre(&nalgebra::Vector3::from(*c), &r);
        let mut wide = ds.camera.clone();
        wide.params[0] = 320.0;
        wide.params[1] = 320.0;
        let img = ds.scene.render(&wide, &pose)?;
        img.rgb.save(out.join(format!("overview{k}.png")))?;
    }
    for i in frames {
        let t = Instant::now();
        let r = ds.render_frame(i)?;
        let dt = t.elapsed().as_secs_f64();
        let p = out.join(format!("frame{i:03}.png"));
        r.rgb.save(&p)?;
        let f = &ds.frames[i];
        println!(
            "frame {i} (seq {} #{}) rendered in {:.3} s -> {}",
            f.sequence,
            f.index,
            dt,
            p.display()
        );
    }
    Ok(())
}
