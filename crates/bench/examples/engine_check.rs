//! One engine against the CPU (Flex): predictions, line encoder, loss terms, gradients
//! and five training steps in one and two gradient groups, for the transformer-only and
//! the graph network (`bench::engines`). Prints the table and a verdict.
//!
//! cargo run --release -p bench --features tch --example engine_check -- --device libtorch:cpu
//! cargo run --release -p bench --features cuda --example engine_check -- --device cuda
//!     [--json]
//! Exit status: 0 the engine agrees, 1 it does not, 2 it cannot run here (one line on
//! stderr saying why and what to do).

use bench::engines::check_agreement;
use model::Device;

fn main() {
    let mut device: Option<Device> = None;
    let mut json = false;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--device" => {
                let v = args.next().unwrap_or_default();
                device = Some(v.parse().unwrap_or_else(|e| {
                    eprintln!("error: --device: {e}");
                    std::process::exit(2)
                }));
            }
            "--json" => json = true,
            other => {
                eprintln!("error: unknown argument {other} (--device DEVICE [--json])");
                std::process::exit(2)
            }
        }
    }
    let Some(device) = device else {
        eprintln!(
            "error: --device DEVICE is required (cuda, cuda:N, libtorch:cpu, libtorch:cuda[:N])"
        );
        std::process::exit(2)
    };
    model::device::explain_gpu_panics(device);
    match check_agreement(device) {
        Ok(a) => {
            print!("{a}");
            if json {
                println!("{}", serde_json::to_string(&a).unwrap_or_default());
            }
            std::process::exit(if a.passed() { 0 } else { 1 })
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2)
        }
    }
}
