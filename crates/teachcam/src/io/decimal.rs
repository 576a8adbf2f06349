//! Numbers in CSV text, written and read without building a `String` per number.
//!
//! - [`TextBuffer::fixed`]: `x` with `N` decimals, byte for byte what `format!("{x:.N$}")`
//!   writes.
//!   That text is the exact binary value of `x` rounded to `N` decimals, the sign kept for
//!   every negative value (`-0.000000` too). Fast path: `y = fl(|x| · 10^N)` (`10^N` exact for
//!   `N ≤ 15`) is within half an ulp of the exact product, so `round(y)` is the exact product's
//!   rounding unless `y` lies within one ulp of a half-integer; then, and for `|y| ≥ 2^52`,
//!   NaN and infinities, the standard formatter writes it. The digits are then those of an
//!   integer, eight at a time in one 64-bit word.
//! - [`parse_f64`]: `str::parse::<f64>` through `fast-float2` (Lemire's algorithm, correctly
//!   rounded like the standard parser, about twice as fast on this file format), the same
//!   syntax accepted.
//!
//! Each is checked against the standard library on random and edge values
//! (`io/decimal.rs` tests).

use std::io::Write as _;

/// Largest number of decimals the fast path of [`push_fixed`] takes (`10^15 < 2^53`).
const MAX_FAST_DECIMALS: usize = 15;

/// `10^k` for `k ≤ 15`, each exact in `f64` and `u64`.
const POW10: [u64; MAX_FAST_DECIMALS + 1] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
    10_000_000_000,
    100_000_000_000,
    1_000_000_000_000,
    10_000_000_000_000,
    100_000_000_000_000,
    1_000_000_000_000_000,
];

/// `2^52`: below it every `f64` has an ulp of at most 1/2 and its floor is exact.
const TWO_POW_52: f64 = 4_503_599_627_370_496.0;

/// Bytes a [`TextBuffer`] holds before it is appended to its output.
const BUFFER_BYTES: usize = 4096;
/// Longest number the fast path writes: a sign, 16 digits, a point and 16 more room (the
/// digits are copied 16 at a time, past the number's end).
const NUMBER_BYTES: usize = 34;

/// CSV text put together in a fixed array and appended to `out` when the array is full and
/// when dropped: each number is written in copies of a fixed size, where appending it to the
/// `Vec` took a call to `memcpy` and a capacity check a field (9 % of `smooth`'s time).
#[derive(Debug)]
pub struct TextBuffer<'a> {
    out: &'a mut Vec<u8>,
    text: [u8; BUFFER_BYTES],
    length: usize,
}

impl<'a> TextBuffer<'a> {
    /// Text to be appended to `out`.
    pub fn new(out: &'a mut Vec<u8>) -> Self {
        Self {
            out,
            text: [0; BUFFER_BYTES],
            length: 0,
        }
    }

    /// Appends what the array holds to `out`.
    fn flush(&mut self) {
        self.out.extend_from_slice(&self.text[..self.length]);
        self.length = 0;
    }

    /// Room for `bytes` more, the array flushed if need be; where they go.
    #[inline(always)]
    fn room(&mut self, bytes: usize) -> usize {
        if self.length + bytes > BUFFER_BYTES {
            self.flush();
        }
        self.length
    }

    /// Appends one byte.
    #[inline(always)]
    pub fn byte(&mut self, byte: u8) {
        let at = self.room(1);
        self.text[at] = byte;
        self.length += 1;
    }

    /// Appends `bytes`.
    pub fn bytes(&mut self, bytes: &[u8]) {
        if bytes.len() > BUFFER_BYTES {
            self.flush();
            self.out.extend_from_slice(bytes);
            return;
        }
        let at = self.room(bytes.len());
        self.text[at..at + bytes.len()].copy_from_slice(bytes);
        self.length += bytes.len();
    }

    /// Appends `value` in decimal.
    pub fn integer(&mut self, value: usize) {
        match u64::try_from(value) {
            Ok(small) if small < POW10[MAX_FAST_DECIMALS] => self.digits(small, 0, false),
            _ => self.bytes(itoa::Buffer::new().format(value).as_bytes()),
        }
    }

    /// Appends `value` with `decimals` digits after the point, exactly as
    /// `format!("{value:.decimals$}")` would.
    pub fn fixed(&mut self, value: f64, decimals: usize) {
        match fixed_digits(value, decimals) {
            Some(scaled) => self.digits(scaled, decimals, value.is_sign_negative()),
            None => {
                self.flush();
                // Writing to a Vec cannot fail.
                let _ = write!(self.out, "{value:.decimals$}");
            }
        }
    }

    /// Appends `scaled / 10^decimals` (`scaled < 10^16`, `decimals ≤ 15`) with `decimals`
    /// digits after the point, a minus before it when `negative`.
    #[inline(always)]
    fn digits(&mut self, scaled: u64, decimals: usize, negative: bool) {
        // Its 16 digits (leading zeros included), the first in the lowest byte, as two
        // independent halves of 8 which run side by side; a point at `decimals ≤ 15` places
        // from the end leaves at least one digit before it. The whole part and the decimals
        // are cut from them by shifts, in registers, and stored in copies of a fixed size
        // (no loop, no branch on the number's length, and no load of bytes just stored in
        // pieces, which the core cannot forward).
        let (high, low) = (scaled / 100_000_000, scaled % 100_000_000);
        let digits =
            u128::from(eight_digits(high as u32)) | u128::from(eight_digits(low as u32)) << 64;
        let point = 16 - decimals;
        let significant = scaled.checked_ilog10().map_or(1, |l| l as usize + 1);
        let whole = significant.saturating_sub(decimals).max(1);
        let first = point - whole;
        let sign = usize::from(negative);
        let at = self.room(NUMBER_BYTES);
        let text = &mut self.text[at..at + NUMBER_BYTES];
        text[0] = b'-';
        text[sign..sign + 16].copy_from_slice(&(digits >> (8 * first)).to_le_bytes());
        let mut length = sign + whole;
        if decimals > 0 {
            text[length] = b'.';
            text[length + 1..length + 17].copy_from_slice(&(digits >> (8 * point)).to_le_bytes());
            length += 1 + decimals;
        }
        self.length += length;
    }
}

impl Drop for TextBuffer<'_> {
    fn drop(&mut self) {
        self.flush();
    }
}

/// The eight decimal digits of `value < 10^8` as ASCII bytes, the first in the lowest byte,
/// leading zeros included: halved into lanes of 32, 16 and 8 bits, each lane's division by
/// 100 and 10 a multiplication and a shift, all lanes at once.
fn eight_digits(value: u32) -> u64 {
    let value = u64::from(value);
    // [abcd, efgh]: (x · 5243) >> 19 is x / 100 for x < 43 699.
    let fours = (value / 10_000) | ((value % 10_000) << 32);
    let high = ((fours * 5243) >> 19) & 0x0000_007f_0000_007f;
    let twos = high | (fours - 100 * high) << 16;
    // [ab, cd, ef, gh]: (x · 103) >> 10 is x / 10 for x < 179.
    let tens = ((twos * 103) >> 10) & 0x000f_000f_000f_000f;
    let ones = tens | (twos - 10 * tens) << 8;
    ones + 0x3030_3030_3030_3030
}

/// `|value| · 10^decimals` rounded to the nearest integer, when `f64` arithmetic decides it
/// (see the module docs); `None` sends the value to the standard formatter.
fn fixed_digits(value: f64, decimals: usize) -> Option<u64> {
    // (Through `i64`, which every number here fits: one instruction a conversion, where
    // `u64`'s take several on x86-64.)
    let unit = *POW10.get(decimals)? as i64;
    let scaled = value.abs() * unit as f64;
    // NaN too: it is not finite.
    if !scaled.is_finite() || scaled >= TWO_POW_52 {
        return None;
    }
    // Truncation is the floor here (`0 ≤ scaled < 2^52`), and a conversion, not a libm call.
    let floor = scaled as i64;
    // Exact: `floor` is 0, or within a factor 2 of `scaled` (Sterbenz).
    let fraction = scaled - floor as f64;
    // One ulp of `scaled` bounds twice the product's rounding error; `fraction - 0.5` is exact
    // where it matters (`fraction` in [1/4, 1]).
    if (fraction - 0.5).abs() <= scaled * f64::EPSILON {
        return None;
    }
    Some(floor.unsigned_abs() + u64::from(fraction > 0.5))
}

/// `text` as an `f64`, accepting what `str::parse::<f64>` accepts (decimal or exponent
/// notation, a sign, `inf`, `infinity`, `nan` in any case) and giving the same bits;
/// `None` when `text` is not a number (the caller names the field).
#[must_use]
pub fn parse_f64(text: &str) -> Option<f64> {
    // fast-float2 also takes a leading `+` and the same special names; it reads exactly what
    // the standard parser reads (tested below).
    fast_float2::parse(text).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn eight_digits_are_the_number_written_with_leading_zeros() {
        let values = (0..100_000_000u32)
            .step_by(9_973)
            .chain((0..24).map(|k| 10u32.pow(k % 8).saturating_sub(k / 8)))
            .chain([99_999_999, 10_000_000, 9_999, 10_000, 43_699, 100]);
        for value in values {
            let text = eight_digits(value).to_le_bytes();
            assert_eq!(
                std::str::from_utf8(&text),
                Ok(format!("{value:08}").as_str())
            );
        }
    }

    fn fixed(value: f64, decimals: usize) -> String {
        let mut out = Vec::new();
        TextBuffer::new(&mut out).fixed(value, decimals);
        String::from_utf8(out).unwrap()
    }

    /// Values where a formatter goes wrong: signs of zero, exact ties in binary (x.5 at every
    /// scale the CSV uses), their neighbours one ulp away, the largest and smallest magnitudes,
    /// the fast path's limit 2^52, carries into a new digit (9.9999995).
    fn edge_values() -> Vec<f64> {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            1.5,
            2.5,
            -2.5,
            0.125,
            0.375,
            1e-7,
            -1e-7,
            5e-7,
            -5e-7,
            4.999_999_5e-7,
            0.000_000_5,
            0.000_001_5,
            0.000_002_5,
            0.000_000_000_5,
            0.000_000_001_5,
            9.999_999_5,
            -9.999_999_5,
            999_999.999_999_5,
            0.1 + 0.2,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            f64::MIN,
            TWO_POW_52 / 1e6,
            TWO_POW_52 / 1e9,
            (TWO_POW_52 - 1.0) / 1e6,
            1e15,
            1e16,
            1e21,
            1e22,
            123_456_789.123_456_78,
            3_600.0,
            3_599.99,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        // Exact binary ties at 6 and 9 decimals: k/2 · 10^-N is a tie only when it is exact,
        // which k/2^m with small m is: 0.0000005 is not exact, but 2^-21 etc. sit near ties.
        for m in 1..60 {
            let v = 2f64.powi(-m);
            values.extend([v, -v, 1.0 + v, 1.0 - v, 300.0 + v]);
        }
        let neighbours: Vec<f64> = values
            .iter()
            .filter(|v| v.is_finite())
            .flat_map(|v| {
                let bits = v.to_bits();
                [
                    f64::from_bits(bits + 1),
                    f64::from_bits(bits.saturating_sub(1)),
                ]
            })
            .collect();
        values.extend(neighbours);
        values
    }

    #[test]
    fn fixed_matches_the_standard_formatter_on_edge_values() {
        for value in edge_values() {
            for decimals in [0, 1, 2, 6, 9, 15, 16, 20] {
                assert_eq!(
                    fixed(value, decimals),
                    format!("{value:.decimals$}"),
                    "{value:e} with {decimals} decimals"
                );
            }
        }
    }

    #[test]
    fn a_text_buffer_holds_what_the_standard_formatter_writes_past_its_array() {
        // Numbers, integers and bytes mixed, some sent to the standard formatter (ties,
        // huge values, NaN), over several times the array's length: the text is flushed in
        // order whenever the array fills.
        let values = edge_values();
        let mut out = Vec::new();
        let mut expected = String::new();
        {
            let mut text = TextBuffer::new(&mut out);
            for round in 0..40usize {
                for (i, &value) in values.iter().enumerate() {
                    let decimals = [6, 9, 0, 15, 17][(i + round) % 5];
                    text.fixed(value, decimals);
                    text.byte(b',');
                    expected.push_str(&format!("{value:.decimals$},"));
                }
                let integer = [
                    0,
                    7,
                    99_999_999,
                    10usize.pow(15) - 1,
                    10usize.pow(15),
                    usize::MAX,
                ][round % 6];
                text.integer(integer);
                text.bytes(b";ok\n");
                expected.push_str(&format!("{integer};ok\n"));
            }
            text.bytes(&[b'x'; BUFFER_BYTES + 3]);
            expected.push_str(&"x".repeat(BUFFER_BYTES + 3));
        }
        assert!(expected.len() > 20 * BUFFER_BYTES);
        assert_eq!(String::from_utf8(out).unwrap(), expected);
    }

    #[test]
    fn fixed_matches_the_standard_formatter_on_every_tie_of_a_grid() {
        // n + 1/2 units of the last decimal, for n around the CSV's magnitudes: most are not
        // exact in binary, so they land just above or below the tie; the fast path must tell
        // which, or hand them to the standard formatter.
        for decimals in [6, 9] {
            let unit = 10f64.powi(-(decimals as i32));
            for n in (0..20_000u64).chain(299_999_990..300_010_000) {
                let value = (n as f64 + 0.5) * unit;
                for v in [value, -value] {
                    assert_eq!(fixed(v, decimals), format!("{v:.decimals$}"));
                }
            }
        }
    }

    #[test]
    fn the_fast_path_can_fail_its_check() {
        // Without the tie check, 0.0000005 (just below the tie in binary) would be judged by
        // `fl(x · 1e6) = 0.5` exactly, which is a tie: the check must send it to the fallback.
        let scaled = 0.000_000_5_f64 * 1e6;
        assert_eq!(scaled, 0.5);
        assert_eq!(fixed_digits(0.000_000_5, 6), None);
        assert_eq!(fixed(0.000_000_5, 6), "0.000000");
        assert_eq!(fixed_digits(0.000_001_6, 6), Some(2));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        #[test]
        fn fixed_matches_the_standard_formatter_on_any_bits(bits in any::<u64>(), decimals in 0usize..18) {
            let value = f64::from_bits(bits);
            prop_assert_eq!(fixed(value, decimals), format!("{value:.decimals$}"));
        }

        #[test]
        fn fixed_matches_the_standard_formatter_at_csv_magnitudes(
            mantissa in -1.0f64..1.0,
            exponent in -12i32..10,
            decimals in prop::sample::select(vec![6usize, 9]),
        ) {
            let value = mantissa * 10f64.powi(exponent);
            prop_assert_eq!(fixed(value, decimals), format!("{value:.decimals$}"));
        }

        #[test]
        fn parse_accepts_and_reads_what_the_standard_parser_does(text in "[-+]?[0-9]{0,20}[.]?[0-9]{0,20}([eE][-+]?[0-9]{0,4})?") {
            let ours = parse_f64(&text).map(f64::to_bits);
            let std = text.parse::<f64>().map(f64::to_bits).ok();
            prop_assert_eq!(ours, std, "{}", text);
        }

        #[test]
        fn parse_agrees_with_the_standard_parser_on_any_text(text in "[-+0-9.eEinftyaINFTYA ]{0,12}") {
            let ours = parse_f64(&text).map(f64::to_bits);
            let std = text.parse::<f64>().map(f64::to_bits).ok();
            prop_assert_eq!(ours, std, "{}", text);
        }

        #[test]
        fn written_numbers_read_back(bits in any::<u64>()) {
            let value = f64::from_bits(bits);
            prop_assume!(value.is_finite());
            prop_assert_eq!(parse_f64(&format!("{value}")).map(f64::to_bits), Some(bits));
        }
    }

    #[test]
    fn parse_agrees_on_special_names() {
        for text in [
            "inf", "-inf", "+inf", "Inf", "INFINITY", "infinity", "nan", "NaN", "-nan", "+NaN",
            "infin", "na", "", "-", "+", ".", "e5", "1e", "1e+", "1.e5", ".5", "5.", "0x10", " 1",
            "1 ", "1_0", "1,5",
        ] {
            let ours = parse_f64(text).map(f64::to_bits);
            let std = text.parse::<f64>().map(f64::to_bits).ok();
            assert_eq!(ours, std, "{text:?}");
        }
    }
}
