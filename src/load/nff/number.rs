//! Reading the plain decimals of an NFF file as `f64`s, exactly as `str::parse::<f64>`
//! reads them, in the same pass that finds the token's end.
//!
//! A plain decimal is an optional `-`, digits and at most one `.`, with 1 to 15 digits in
//! all. It is an integer m < 10^15 < 2^53 over a power of ten 10^k with k ≤ 15 ≤ 22: both
//! are exact `f64`s, so the one IEEE division m / 10^k is the correctly rounded value of
//! the decimal, which is what `str::parse` (correctly rounded too) gives; the sign is exact
//! as rounding to nearest is symmetric. The cursor hands every other token (exponents, a
//! `+`, more digits, `inf`, `nan`, words) to `str::parse`.

/// 10^k for k = 0..=15, each exact in an `f64`.
const POWERS_OF_TEN: [f64; 16] =
    [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// The plain decimal at the start of `bytes` and its length in bytes: the longest prefix
/// of the form `-?[0-9]*(\.[0-9]*)?`, if it has 1 to 15 digits. It is the whole token's
/// value only if the token ends where the prefix does.
#[inline]
pub(super) fn plain_decimal(bytes: &[u8]) -> Option<(f64, usize)> {
    let negative = bytes.first() == Some(&b'-');
    let mut i = usize::from(negative);
    let mut mantissa = 0u64;
    let mut digits = 0;
    let mut run = |i: &mut usize, digits: &mut usize| {
        while let Some(d) = bytes.get(*i).map(|b| b.wrapping_sub(b'0')).filter(|d| *d < 10) {
            // Past 15 digits the value may not be exact: the caller falls back anyway.
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            *digits += 1;
            *i += 1;
        }
    };
    run(&mut i, &mut digits);
    let mut decimals = 0;
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        run(&mut i, &mut decimals);
    }
    digits += decimals;
    if digits == 0 || digits > 15 {
        return None;
    }
    let value = mantissa as f64 / POWERS_OF_TEN[decimals];
    Some((if negative { -value } else { value }, i))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// A whole token read as the cursor reads it.
    fn read(text: &str) -> Result<f64, std::num::ParseFloatError> {
        match plain_decimal(text.as_bytes()) {
            Some((value, len)) if len == text.len() => Ok(value),
            _ => text.parse(),
        }
    }

    #[track_caller]
    fn same(text: &str) {
        match (read(text), text.parse::<f64>()) {
            (Ok(a), Ok(b)) => assert_eq!(a.to_bits(), b.to_bits(), "{text:?}: {a} against {b}"),
            (Err(_), Err(_)) => {}
            (a, b) => panic!("{text:?}: {a:?} against {b:?}"),
        }
    }

    #[test]
    fn plain_and_odd_tokens_read_as_str_parse_reads_them() {
        for text in [
            "0",
            "-0",
            "-0.0",
            "0.",
            ".5",
            "-.5",
            ".",
            "-",
            "-.",
            "",
            "1.",
            "007",
            "3.14159",
            "-0.996094",
            "4.81884",
            "0.1",
            "0.3",
            "123456789012345",
            "1234567890123456",
            "0.000000000000001",
            "9007199254740993",
            "99999999999999.9",
            "1.2.3",
            "1-2",
            "+1",
            "1e5",
            "1E-5",
            "inf",
            "-inf",
            "NaN",
            "infinity",
            "0x10",
            "1_0",
            "١",
            "--1",
            " 1",
            "99999999999999999999999",
            "0.99999999999999999999999999",
        ] {
            same(text);
        }
    }

    proptest! {
        #[test]
        fn random_decimals_read_as_str_parse_reads_them(
            text in "[-+]?[0-9]{0,18}(\\.[0-9]{0,18})?([eE][-+]?[0-9]{1,3})?"
        ) {
            same(&text);
        }

        #[test]
        fn random_bytes_read_as_str_parse_reads_them(text in "[-+.0-9eE]{0,20}") {
            same(&text);
        }
    }
}
