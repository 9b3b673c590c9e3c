//! Intel AMX tiles for products of bf16 matrices with f32 sums (`bf16_products.rs`).
//!
//! Why: the main job's training step is three matrix products per dense layer, and on
//! the AVX-512 cores of this project's Intel machines gemm's f32 kernels already run them
//! near the cores' FMA rate (docs/performance.md, "The main job's step"). An AMX tile
//! instruction (`TDPBF16PS`) multiplies a 16 x 32 bf16 tile by a 32 x 16 one into 16 x 16
//! f32 sums; on the same cores a block of those ran 256 x 512 x 512 at about 510 GFLOP/s
//! on one thread, against gemm's f32 152 GFLOP/s (docs/performance.md, "bf16 products on
//! AMX tiles").
//!
//! Rust has no stable AMX intrinsics, so the kernel is inline assembly. Linux hands a
//! process the tile registers only after it asks (`arch_prctl(ARCH_REQ_XCOMP_PERM)`),
//! once per process; each thread loads the tile configuration before it uses the tiles
//! and releases them after, so a thread switch saves no tile state it does not need.

/// Whether this CPU and kernel give the process AMX tiles with bf16 products; asked
/// once, the permission requested on the first call.
pub(crate) fn available() -> bool {
    static AVAILABLE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVAILABLE.get_or_init(detect)
}

#[cfg(all(target_arch = "x86_64", target_os = "linux"))]
fn detect() -> bool {
    // CPUID leaf 7 (within the maximum leaf, checked first): EDX bit 22 = AMX-BF16,
    // bit 24 = AMX-TILE.
    let has_cpu = std::arch::x86_64::__cpuid(0).eax >= 7 && {
        let edx = std::arch::x86_64::__cpuid_count(7, 0).edx;
        edx & (1 << 22) != 0 && edx & (1 << 24) != 0
    };
    if !has_cpu {
        return false;
    }
    const ARCH_REQ_XCOMP_PERM: libc::c_long = 0x1023;
    const XFEATURE_XTILEDATA: libc::c_long = 18;
    // SAFETY: arch_prctl only grants (or refuses) the process the tile state; on kernels
    // without it the call fails and the tiles stay unused.
    unsafe {
        libc::syscall(
            libc::SYS_arch_prctl,
            ARCH_REQ_XCOMP_PERM,
            XFEATURE_XTILEDATA,
        ) == 0
    }
}

#[cfg(not(all(target_arch = "x86_64", target_os = "linux")))]
fn detect() -> bool {
    false
}

/// Rows and columns of one output block: 2 x 2 tiles of 16 x 16 f32.
pub(crate) const BLOCK: usize = 32;
/// bf16 elements of the summed dimension per tile instruction.
pub(crate) const K_STEP: usize = 32;

/// C block (32 x 32 f32 at `c`, rows `c_stride` bytes apart) = A rows (32 x `k`
/// bf16 at `a`, rows `a_stride` bytes apart) x B columns (the pair-interleaved layout of
/// `bf16_products.rs`: `k / 2` rows of 32 column pairs at `b`, rows `b_stride` bytes
/// apart), for every block of `blocks`: (a, b, c) pointers.
///
/// SAFETY: [`available`] returned true; `k` is a positive multiple of [`K_STEP`]; every
/// block's pointers reach the sizes above through their strides, A and B readable, C
/// writable.
#[cfg(target_arch = "x86_64")]
pub(crate) unsafe fn blocks(
    blocks: impl Iterator<Item = (*const u16, *const u16, *mut f32)>,
    k: usize,
    a_stride: usize,
    b_stride: usize,
    c_stride: usize,
) {
    use std::arch::asm;
    // Palette 1; tiles 0-7 all 16 rows of 64 bytes (16 f32 or 32 bf16).
    #[repr(C, align(64))]
    struct TileConfig([u8; 64]);
    let mut cfg = TileConfig([0; 64]);
    cfg.0[0] = 1;
    for t in 0..8 {
        cfg.0[16 + 2 * t] = 64;
        cfg.0[48 + t] = 16;
    }
    let steps = k / K_STEP;
    // SAFETY: the caller's promises; the configuration is valid for palette 1.
    unsafe {
        asm!("ldtilecfg [{}]", in(reg) cfg.0.as_ptr(), options(nostack, readonly));
        for (a, b, c) in blocks {
            let a2 = (a as *const u8).add(16 * a_stride);
            let b2 = (b as *const u8).add(64);
            let c = c as *mut u8;
            asm!(
                "tilezero tmm0",
                "tilezero tmm1",
                "tilezero tmm2",
                "tilezero tmm3",
                "2:",
                "tileloadd tmm4, [{a} + {sa}*1]",
                "tileloadd tmm6, [{b} + {sb}*1]",
                "tileloadd tmm5, [{a2} + {sa}*1]",
                "tileloadd tmm7, [{b2} + {sb}*1]",
                "tdpbf16ps tmm0, tmm4, tmm6",
                "tdpbf16ps tmm1, tmm4, tmm7",
                "tdpbf16ps tmm2, tmm5, tmm6",
                "tdpbf16ps tmm3, tmm5, tmm7",
                "add {a}, 64",
                "add {a2}, 64",
                "add {b}, {b_step}",
                "add {b2}, {b_step}",
                "dec {n}",
                "jnz 2b",
                "tilestored [{c0} + {sc}*1], tmm0",
                "tilestored [{c1} + {sc}*1], tmm1",
                "tilestored [{c2} + {sc}*1], tmm2",
                "tilestored [{c3} + {sc}*1], tmm3",
                a = inout(reg) a as *const u8 => _,
                a2 = inout(reg) a2 => _,
                b = inout(reg) b as *const u8 => _,
                b2 = inout(reg) b2 => _,
                sa = in(reg) a_stride,
                sb = in(reg) b_stride,
                sc = in(reg) c_stride,
                b_step = in(reg) 16 * b_stride,
                n = inout(reg) steps => _,
                c0 = in(reg) c,
                c1 = in(reg) c.add(64),
                c2 = in(reg) c.add(16 * c_stride),
                c3 = in(reg) c.add(16 * c_stride + 64),
                options(nostack),
            );
        }
        asm!("tilerelease", options(nostack, nomem));
    }
}

#[cfg(not(target_arch = "x86_64"))]
pub(crate) unsafe fn blocks(
    _blocks: impl Iterator<Item = (*const u16, *const u16, *mut f32)>,
    _k: usize,
    _a_stride: usize,
    _b_stride: usize,
    _c_stride: usize,
) {
    unreachable!("AMX is x86-64 only; available() is false elsewhere")
}
