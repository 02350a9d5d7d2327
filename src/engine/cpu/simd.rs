//! The engine's one SIMD seam: a 4-wide f32 vector over SSE, and the test that picks the f32
//! specialisations. Every x86 intrinsic of the engine's CPU path lives here, so that a call
//! site reads as arithmetic. SSE and SSE2 are part of the x86-64 baseline, so each operation
//! is one instruction (VEX-encoded when inlined into a function compiled also for AVX2, as
//! the pair pass and kick are). Each method is the one intrinsic it wraps, so a site keeps its
//! operations and their order, and so its bits.

use std::any::TypeId;
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, Mul, Sub};

use crate::engine::real::{Real, V3};

/// Whether the engine's precision `R` is f32: the sites with a 4-wide f32 path test it (a
/// constant after monomorphisation) and cast their values to the f32 types.
#[inline(always)]
pub(super) fn is_f32<R: Real>() -> bool {
    TypeId::of::<R>() == TypeId::of::<f32>()
}

/// Four f32 in one SSE register. The engine's records keep a 3-vector and a fourth value in
/// 16 bytes (`Kin`), so the x, y, z places are a vector and the fourth rides along.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(super) struct F32x4(__m128);

impl F32x4 {
    /// (a, b, c, d).
    #[inline(always)]
    pub(super) fn new(a: f32, b: f32, c: f32, d: f32) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_setr_ps(a, b, c, d) })
    }

    /// (x, x, x, x).
    #[inline(always)]
    pub(super) fn splat(x: f32) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_set1_ps(x) })
    }

    /// The four f32 at `p`.
    ///
    /// # Safety
    /// `p` is 16-byte aligned and 16 bytes from it are readable.
    #[inline(always)]
    pub(super) unsafe fn load(p: *const f32) -> Self {
        // SAFETY: the caller's.
        Self(unsafe { _mm_load_ps(p) })
    }

    /// Writes the four places to `p`.
    ///
    /// # Safety
    /// `p` is 16-byte aligned and 16 bytes from it are writable.
    #[inline(always)]
    pub(super) unsafe fn store(self, p: *mut f32) {
        // SAFETY: the caller's.
        unsafe { _mm_store_ps(p, self.0) }
    }

    /// An array's four places (no alignment needed).
    #[inline(always)]
    pub(super) fn from_array(a: &[f32; 4]) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline; 16 bytes at `a`.
        Self(unsafe { _mm_loadu_ps(a.as_ptr()) })
    }

    /// (x, y, z, 0) from a 3-vector, read within its 12 bytes.
    #[inline(always)]
    pub(super) fn from_v3(v: &V3<f32>) -> Self {
        let p = (v as *const V3<f32>).cast::<f32>();
        // SAFETY: SSE2 is part of the x86-64 baseline; `V3<f32>` is repr(C) [x, y, z]: 8 bytes
        // at p and 4 at p + 2, within the vector. (x, y, 0, 0) and (z, 0, 0, 0) give
        // (x, y, z, 0).
        unsafe {
            let xy = _mm_castpd_ps(_mm_load_sd(p.cast::<f64>()));
            Self(_mm_movelh_ps(xy, _mm_load_ss(p.add(2))))
        }
    }

    /// The first three places (x, y, z).
    #[inline(always)]
    pub(super) fn xyz(self) -> V3<f32> {
        let q = self.0;
        // SAFETY: SSE is part of the x86-64 baseline.
        unsafe {
            V3::new(
                _mm_cvtss_f32(q),
                _mm_cvtss_f32(_mm_shuffle_ps::<0b01>(q, q)),
                _mm_cvtss_f32(_mm_movehl_ps(q, q)),
            )
        }
    }

    /// (x + y) + z, as `V3::norm2` sums its squares.
    #[inline(always)]
    pub(super) fn sum_xyz(self) -> f32 {
        let q = self.0;
        // SAFETY: SSE is part of the x86-64 baseline.
        unsafe {
            _mm_cvtss_f32(_mm_add_ss(
                _mm_add_ss(q, _mm_shuffle_ps::<0b01>(q, q)),
                _mm_movehl_ps(q, q),
            ))
        }
    }

    /// Per place, all ones where `self > o`, else zero.
    #[inline(always)]
    pub(super) fn gt(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_cmpgt_ps(self.0, o.0) })
    }

    /// Per place, all ones where `self < o`, else zero.
    #[inline(always)]
    pub(super) fn lt(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_cmplt_ps(self.0, o.0) })
    }

    /// Per place, all ones where `self >= o`, else zero.
    #[inline(always)]
    pub(super) fn ge(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_cmpge_ps(self.0, o.0) })
    }

    /// Whether all four places of a mask (`gt`, `lt`, `ge`) are set.
    #[inline(always)]
    pub(super) fn all(self) -> bool {
        // SAFETY: SSE is part of the x86-64 baseline.
        unsafe { _mm_movemask_ps(self.0) == 0b1111 }
    }
}

impl Add for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_add_ps(self.0, o.0) })
    }
}

impl Sub for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_sub_ps(self.0, o.0) })
    }
}

impl Mul for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_mul_ps(self.0, o.0) })
    }
}

/// Bitwise and: a mask (`gt`, `lt`, `ge`) picks places of a value.
impl BitAnd for F32x4 {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        // SAFETY: SSE is part of the x86-64 baseline.
        Self(unsafe { _mm_and_ps(self.0, o.0) })
    }
}
