//! Contact sheet of frames with the scene's visible 3D edges projected on them (exact
//! geometry check by eye). Usage: cargo run --release -p synth --example edges -- OUT.png [SEED] [FRAME...]

use geometry::lines::{clip_segment_to_image, clip_to_near_plane};
use synth::{SynthDataset, contact_sheet, preview::SheetFrame};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = args
        .get(1)
        .cloned()
        .unwrap_or("/tmp/synth_edges.png".into());
    let seed: u64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(0);
    let frames: Vec<usize> = if args.len() > 3 {
        args[3..]
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![0, 60, 120, 180]
    };
    let ds = SynthDataset::new(300, seed, false)?;
    let mut sheet: Vec<SheetFrame> = Vec::new();
    for i in frames {
        let f = &ds.frames[i];
        let r = ds.render_frame(i)?;
        let c = f.pose.centre();
        let mut segs = Vec::new();
        for e in ds.scene.edges() {
            // Draw the visible stretches, sampled every 2 cm.
            let n = ((e.length() / 0.02).ceil() as usize).max(1);
            let vis: Vec<bool> = (0..=n)
                .map(|k| {
                    ds.scene
                        .is_visible(&c, &(e.a + (e.b - e.a) * (k as f64 / n as f64)), 2e-3)
                })
                .collect();
            let mut k = 0;
            while k < n {
                if !(vis[k] && vis[k + 1]) {
                    k += 1;
                    continue;
                }
                let s = k;
                while k < n && vis[k] && vis[k + 1] {
                    k += 1;
                }
                let a = e.a + (e.b - e.a) * (s as f64 / n as f64);
                let b = e.a + (e.b - e.a) * (k as f64 / n as f64);
                let Some((ca, cb)) = clip_to_near_plane(
                    &f.pose.transform_point(&a),
                    &f.pose.transform_point(&b),
                    0.05,
                ) else {
                    continue;
                };
                let (Some(pa), Some(pb)) = (ds.camera.project(&ca), ds.camera.project(&cb)) else {
                    continue;
                };
                if let Some(s2) =
                    clip_segment_to_image(&geometry::lines::Segment2::new(pa, pb), 640.0, 480.0)
                {
                    segs.push(s2.to_array());
                }
            }
        }
        println!("frame {i}: {} visible edge pieces", segs.len());
        sheet.push((r.rgb, Vec::new(), segs));
    }
    contact_sheet(&sheet, 2).save(&out)?;
    println!("{out}");
    Ok(())
}
