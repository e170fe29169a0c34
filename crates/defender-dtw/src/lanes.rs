//! Portable fixed-width lane vectors (`[f32; L]`) that LLVM turns into SIMD registers, and the
//! CPU-feature dispatch that compiles each kernel once per instruction set.
//!
//! Every kernel in this crate is one generic `#[inline(always)]` function over `const L` (lanes)
//! and `const FMA`; [`crate::isa::Isa`] picks at run time which monomorphic copy to call, each compiled inside
//! a `#[target_feature]` wrapper so the lane arrays become AVX2 / AVX-512 registers.

/// A vector of `L` lanes of `f32`.
pub(crate) type V<const L: usize> = [f32; L];

/// Lanes of the streaming layout (references interleaved across lanes).
pub(crate) const GROUP: usize = 8;

/// Padding (in elements) kept on both sides of reversed, dimension-major reference storage,
/// enough for the widest anti-diagonal strip (16 lanes).
pub(crate) const PAD: usize = 15;

#[inline(always)]
pub(crate) fn splat<const L: usize>(v: f32) -> V<L> {
    [v; L]
}

#[inline(always)]
pub(crate) fn add<const L: usize>(a: V<L>, b: V<L>) -> V<L> {
    std::array::from_fn(|k| a[k] + b[k])
}

#[inline(always)]
pub(crate) fn min<const L: usize>(a: V<L>, b: V<L>) -> V<L> {
    // `if` rather than f32::min: the inputs are never NaN, and this lowers to one vminps.
    std::array::from_fn(|k| if a[k] < b[k] { a[k] } else { b[k] })
}

/// `acc + (a - b)^2`, fused when `FMA`.
#[inline(always)]
pub(crate) fn sq_diff_acc<const L: usize, const FMA: bool>(acc: V<L>, a: V<L>, b: V<L>) -> V<L> {
    std::array::from_fn(|k| {
        let d = a[k] - b[k];
        if FMA { d.mul_add(d, acc[k]) } else { acc[k] + d * d }
    })
}

/// `acc + |a - b|`.
#[inline(always)]
pub(crate) fn abs_diff_acc<const L: usize>(acc: V<L>, a: V<L>, b: V<L>) -> V<L> {
    std::array::from_fn(|k| acc[k] + (a[k] - b[k]).abs())
}

#[inline(always)]
pub(crate) fn sqrt<const L: usize>(a: V<L>) -> V<L> {
    std::array::from_fn(|k| a[k].sqrt())
}

/// Lane `k` gets `a[k - 1]`, lane 0 gets `first`.
#[inline(always)]
pub(crate) fn shift_in<const L: usize>(first: f32, a: V<L>) -> V<L> {
    std::array::from_fn(|k| if k == 0 { first } else { a[k - 1] })
}

/// Loads `L` consecutive values starting at `s[at]`.
#[inline(always)]
pub(crate) fn load<const L: usize>(s: &[f32], at: usize) -> V<L> {
    let mut out = [0.0; L];
    out.copy_from_slice(&s[at..at + L]);
    out
}

/// Defines `$name(isa, args..) -> $ret` that calls the generic `$kernel::<L, FMA>(args..)` compiled
/// for `isa`: 16 lanes under AVX-512, 8 under AVX2, `$portable_lanes` otherwise. `$lanes16` lets a
/// kernel whose layout fixes the lane count (the streaming one) use 8 lanes under AVX-512 too.
macro_rules! dispatch {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty
        => $kernel:ident, lanes: ($l512:expr, $l2:expr, $lp:expr)) => {
        $(#[$m])*
        $vis fn $name(isa: $crate::isa::Isa, $($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx2,fma")]
                fn avx512($($arg: $ty),*) -> $ret { $kernel::<{ $l512 }, true>($($arg),*) }
                #[target_feature(enable = "avx2,fma")]
                fn avx2($($arg: $ty),*) -> $ret { $kernel::<{ $l2 }, true>($($arg),*) }
                match isa {
                    // SAFETY: `Isa::detect` returned this variant only after checking that the CPU
                    // has every feature the wrapper enables (`kernels::with_kernel` forces only a
                    // variant whose features are a subset of the detected one's).
                    $crate::isa::Isa::Avx512 => return unsafe { avx512($($arg),*) },
                    // SAFETY: as above.
                    $crate::isa::Isa::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::isa::Isa::Portable => {}
                }
            }
            let _ = isa;
            $kernel::<{ $lp }, false>($($arg),*)
        }
    };
}
pub(crate) use dispatch;
