//! Proofs that the processor has an instruction set: a value of [`Avx`] or [`AvxFma`]
//! exists only where the run-time check said so, because [`Avx::detect`] and
//! [`AvxFma::detect`] are the only ways to make one (their field is private). Code that
//! runs AVX instructions takes such a token, so its soundness follows from the types,
//! not from a comment about who calls it.

/// The processor has AVX.
#[derive(Clone, Copy, Debug)]
pub struct Avx(());

/// The processor has AVX and FMA.
#[derive(Clone, Copy, Debug)]
pub struct AvxFma(());

impl Avx {
    /// The token, where the processor has AVX (never on other architectures).
    pub fn detect() -> Option<Avx> {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx") {
            return Some(Avx(()));
        }
        None
    }
}

impl AvxFma {
    /// The token, where the processor has AVX and FMA (never on other architectures).
    pub fn detect() -> Option<AvxFma> {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx") && std::is_x86_feature_detected!("fma") {
            return Some(AvxFma(()));
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_follow_the_processor() {
        #[cfg(target_arch = "x86_64")]
        {
            assert_eq!(
                Avx::detect().is_some(),
                std::is_x86_feature_detected!("avx")
            );
            let both = std::is_x86_feature_detected!("avx") && std::is_x86_feature_detected!("fma");
            assert_eq!(AvxFma::detect().is_some(), both);
        }
        #[cfg(not(target_arch = "x86_64"))]
        assert!(Avx::detect().is_none() && AvxFma::detect().is_none());
    }
}
