//! f32 lane vectors for the fused pass of `fused.rs`: [`V4`] (SSE2 on x86-64, always
//! there; plain arrays elsewhere) and, on x86-64, [`V8`] (AVX) and [`V8F`] (AVX with fused
//! multiply-adds).
//!
//! Sound by construction: a vector is made only by [`Lanes::zero`], [`Lanes::splat`] or
//! [`Lanes::load`], each of which takes the lane type's [`Lanes::Cpu`] token, and the
//! wide types' tokens ([`Avx`], [`AvxFma`]) exist only where the processor has those
//! instructions (`crate::cpu`). So wherever a `V8` or `V8F` value exists, its intrinsics
//! are available, and every method on it is safe to call.

#[cfg(target_arch = "x86_64")]
use crate::cpu::{Avx, AvxFma};
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// The x86-64 baseline (SSE2), or plain arrays elsewhere: always there.
#[derive(Clone, Copy, Debug)]
pub struct Baseline;

/// The operations of the fused pass on `N` lanes.
pub trait Lanes: Copy {
    /// Proof that the processor runs this type's instructions.
    type Cpu: Copy;
    /// Number of lanes.
    const N: usize;
    fn zero(cpu: Self::Cpu) -> Self;
    fn splat(cpu: Self::Cpu, x: f32) -> Self;
    /// The `N` values at `s[at..at + N]`.
    fn load(cpu: Self::Cpu, s: &[f32], at: usize) -> Self;
    fn store(self, s: &mut [f32], at: usize);
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    /// Sum of the lanes.
    fn sum(self) -> f32;
    /// self + a·b (fused where the build has FMA).
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        self.add(a.mul(b))
    }
    /// The lane sums of eight vectors.
    #[inline(always)]
    fn sum8(v: [Self; 8]) -> [f32; 8] {
        v.map(Self::sum)
    }
}

/// Four f32 lanes.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub struct V4(__m128);
/// Four f32 lanes.
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy)]
pub struct V4([f32; 4]);

/// `impl Lanes` for a vector type over x86-64 intrinsics: its token, its lane count, then the
/// intrinsics for zero, splat, unaligned load and store, add, sub and mul, then the
/// body of `sum`, then any overridden methods. Loads and stores go through slices of
/// exactly N values.
#[cfg(target_arch = "x86_64")]
macro_rules! intrinsic_lanes {
    ($v:ident, $cpu:ty, $n:literal, $zero:ident, $splat:ident, $load:ident, $store:ident,
     $add:ident, $sub:ident, $mul:ident, |$x:ident| $sum:block $(, $extra:item)*) => {
        impl Lanes for $v {
            $($extra)*
            type Cpu = $cpu;
            const N: usize = $n;
            #[inline(always)]
            fn zero(_: $cpu) -> $v {
                $v(unsafe { $zero() })
            }
            #[inline(always)]
            fn splat(_: $cpu, x: f32) -> $v {
                $v(unsafe { $splat(x) })
            }
            #[inline(always)]
            fn load(_: $cpu, s: &[f32], at: usize) -> $v {
                let s = &s[at..at + $n];
                $v(unsafe { $load(s.as_ptr()) })
            }
            #[inline(always)]
            fn store(self, s: &mut [f32], at: usize) {
                let s = &mut s[at..at + $n];
                unsafe { $store(s.as_mut_ptr(), self.0) }
            }
            #[inline(always)]
            fn add(self, o: $v) -> $v {
                $v(unsafe { $add(self.0, o.0) })
            }
            #[inline(always)]
            fn sub(self, o: $v) -> $v {
                $v(unsafe { $sub(self.0, o.0) })
            }
            #[inline(always)]
            fn mul(self, o: $v) -> $v {
                $v(unsafe { $mul(self.0, o.0) })
            }
            #[inline(always)]
            fn sum(self) -> f32 {
                let $x = self.0;
                unsafe { $sum }
            }
        }
    };
}

// SAFETY (all `unsafe` blocks of this impl): SSE and SSE2 are part of the x86-64
// baseline, so the intrinsics are always available.
#[cfg(target_arch = "x86_64")]
intrinsic_lanes!(
    V4,
    Baseline,
    4,
    _mm_setzero_ps,
    _mm_set1_ps,
    _mm_loadu_ps,
    _mm_storeu_ps,
    _mm_add_ps,
    _mm_sub_ps,
    _mm_mul_ps,
    |x| {
        let s2 = _mm_add_ps(x, _mm_movehl_ps(x, x));
        _mm_cvtss_f32(_mm_add_ss(s2, _mm_shuffle_ps::<1>(s2, s2)))
    }
);

#[cfg(not(target_arch = "x86_64"))]
impl Lanes for V4 {
    type Cpu = Baseline;
    const N: usize = 4;
    #[inline(always)]
    fn zero(_: Baseline) -> V4 {
        V4([0.0; 4])
    }
    #[inline(always)]
    fn splat(_: Baseline, x: f32) -> V4 {
        V4([x; 4])
    }
    #[inline(always)]
    fn load(_: Baseline, s: &[f32], at: usize) -> V4 {
        V4([s[at], s[at + 1], s[at + 2], s[at + 3]])
    }
    #[inline(always)]
    fn store(self, s: &mut [f32], at: usize) {
        s[at..at + 4].copy_from_slice(&self.0);
    }
    #[inline(always)]
    fn add(self, o: V4) -> V4 {
        V4(std::array::from_fn(|i| self.0[i] + o.0[i]))
    }
    #[inline(always)]
    fn sub(self, o: V4) -> V4 {
        V4(std::array::from_fn(|i| self.0[i] - o.0[i]))
    }
    #[inline(always)]
    fn mul(self, o: V4) -> V4 {
        V4(std::array::from_fn(|i| self.0[i] * o.0[i]))
    }
    #[inline(always)]
    fn sum(self) -> f32 {
        (self.0[0] + self.0[2]) + (self.0[1] + self.0[3])
    }
}

/// Eight f32 lanes (AVX): made only with an [`Avx`] token.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub struct V8(__m256);

/// Eight f32 lanes with fused multiply-add (AVX and FMA): made only with an [`AvxFma`]
/// token.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub struct V8F(__m256);

/// The lane sums of eight AVX vectors by a transposing tree of horizontal adds (7
/// instructions instead of 8 separate reductions). Safety: call only where the
/// processor has AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sum8_avx(v: [__m256; 8]) -> [f32; 8] {
    let (t0, t1) = (_mm256_hadd_ps(v[0], v[1]), _mm256_hadd_ps(v[2], v[3]));
    let (t2, t3) = (_mm256_hadd_ps(v[4], v[5]), _mm256_hadd_ps(v[6], v[7]));
    let (u0, u1) = (_mm256_hadd_ps(t0, t1), _mm256_hadd_ps(t2, t3));
    let lo = _mm256_permute2f128_ps::<0x20>(u0, u1);
    let hi = _mm256_permute2f128_ps::<0x31>(u0, u1);
    let mut out = [0.0f32; 8];
    _mm256_storeu_ps(out.as_mut_ptr(), _mm256_add_ps(lo, hi));
    out
}

/// The horizontal sum of one AVX vector. Safety: call only where the processor has
/// AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sum_avx(x: __m256) -> f32 {
    let s4 = _mm_add_ps(_mm256_castps256_ps128(x), _mm256_extractf128_ps::<1>(x));
    let s2 = _mm_add_ps(s4, _mm_movehl_ps(s4, s4));
    _mm_cvtss_f32(_mm_add_ss(s2, _mm_shuffle_ps::<1>(s2, s2)))
}

// SAFETY (all `unsafe` blocks of this impl): the AVX intrinsics are sound where the
// processor has AVX, and it has: a `V8` is made only with an `Avx` token (the methods
// taking `self` run on a value that exists, the others take the token), and an `Avx`
// exists only where the run-time check found AVX (`crate::cpu`). For speed the methods
// are inlined into functions compiled with AVX enabled (`Single::refine_avx`).
#[cfg(target_arch = "x86_64")]
intrinsic_lanes!(
    V8,
    Avx,
    8,
    _mm256_setzero_ps,
    _mm256_set1_ps,
    _mm256_loadu_ps,
    _mm256_storeu_ps,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    |x| { sum_avx(x) },
    #[inline(always)]
    fn sum8(v: [V8; 8]) -> [f32; 8] {
        unsafe { sum8_avx(v.map(|x| x.0)) }
    }
);

// SAFETY (all `unsafe` blocks of this impl): the AVX and FMA intrinsics are sound
// where the processor has both, and it has: a `V8F` is made only with an `AvxFma`
// token, which exists only where the run-time check found both (`crate::cpu`).
#[cfg(target_arch = "x86_64")]
intrinsic_lanes!(
    V8F,
    AvxFma,
    8,
    _mm256_setzero_ps,
    _mm256_set1_ps,
    _mm256_loadu_ps,
    _mm256_storeu_ps,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    |x| { sum_avx(x) },
    #[inline(always)]
    fn sum8(v: [V8F; 8]) -> [f32; 8] {
        unsafe { sum8_avx(v.map(|x| x.0)) }
    },
    #[inline(always)]
    fn mul_add(self, a: V8F, b: V8F) -> V8F {
        V8F(unsafe { _mm256_fmadd_ps(a.0, b.0, self.0) })
    }
);
