//! Compiles proto/pl2map/frame_labels.proto with protox (a pure-Rust protobuf
//! compiler, so no `protoc` is needed) into
//! - `frame_labels.fds`: the binary FileDescriptorSet embedded in every shard as the
//!   `pl2map.FrameLabels` schema (no source info: only what a decoder needs);
//! - `pl2map.rs`: the prost types, generated from that same descriptor set.

use std::path::PathBuf;

const PROTO: &str = "proto/pl2map/frame_labels.proto";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-changed={PROTO}");
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    let mut compiler = protox::Compiler::new(["proto"])?;
    compiler.include_imports(true).include_source_info(false);
    compiler.open_file("pl2map/frame_labels.proto")?;
    std::fs::write(
        out.join("frame_labels.fds"),
        compiler.encode_file_descriptor_set(),
    )?;
    prost_build::Config::new()
        .out_dir(&out)
        .compile_fds(compiler.file_descriptor_set())?;
    Ok(())
}
