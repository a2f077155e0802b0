// ---- IEEE binary64 in software (WGSL has no f64) ----
// A double is its bits as vec2<u32>(low word, high word). Add, subtract, multiply and divide round to nearest even
// as IEEE 754 does, so the codecs gbuf computes in f64 give the same bits here. Results below 2^-1022 flush to
// zero: from f32 inputs the codecs never come near them (tested against Rust's f64 on llvmpipe).

fn gbuf_adc(a: u32, b: u32) -> vec2<u32> {
    let s = a + b;
    return vec2<u32>(s, select(0u, 1u, s < a));
}

// 32 × 32 → 64 bits, (low, high).
fn gbuf_mul32(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

fn gbuf_add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = gbuf_adc(a.x, b.x);
    return vec2<u32>(lo.x, a.y + b.y + lo.y);
}

fn gbuf_sub64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    return vec2<u32>(a.x - b.x, a.y - b.y - select(0u, 1u, a.x < b.x));
}

fn gbuf_lt64(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.y < b.y || (a.y == b.y && a.x < b.x);
}

fn gbuf_shl64(a: vec2<u32>, s: u32) -> vec2<u32> {
    if (s == 0u) {
        return a;
    }
    if (s >= 64u) {
        return vec2<u32>(0u, 0u);
    }
    if (s >= 32u) {
        return vec2<u32>(0u, a.x << (s - 32u));
    }
    return vec2<u32>(a.x << s, (a.y << s) | (a.x >> (32u - s)));
}

fn gbuf_shr64(a: vec2<u32>, s: u32) -> vec2<u32> {
    if (s == 0u) {
        return a;
    }
    if (s >= 64u) {
        return vec2<u32>(0u, 0u);
    }
    if (s >= 32u) {
        return vec2<u32>(a.y >> (s - 32u), 0u);
    }
    return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
}

// a >> s with every bit shifted out ORed into bit 0 (the sticky bit of rounding).
fn gbuf_shr64_sticky(a: vec2<u32>, s: u32) -> vec2<u32> {
    let r = gbuf_shr64(a, s);
    let back = gbuf_shl64(r, s);
    let lost = s >= 64u || back.x != a.x || back.y != a.y;
    return vec2<u32>(r.x | select(0u, 1u, lost && (a.x | a.y) != 0u), r.y);
}

fn gbuf_clz64(a: vec2<u32>) -> u32 {
    return select(countLeadingZeros(a.y), 32u + countLeadingZeros(a.x), a.y == 0u);
}

fn gbuf_d_exp(a: vec2<u32>) -> u32 {
    return (a.y >> 20u) & 0x7ffu;
}

// The 53-bit significand with its leading one (bit 52), for a normal number.
fn gbuf_d_sig(a: vec2<u32>) -> vec2<u32> {
    return vec2<u32>(a.x, (a.y & 0xfffffu) | 0x100000u);
}

fn gbuf_d_is_nan(a: vec2<u32>) -> bool {
    return gbuf_d_exp(a) == 0x7ffu && ((a.y & 0xfffffu) | a.x) != 0u;
}

fn gbuf_d_is_inf(a: vec2<u32>) -> bool {
    return gbuf_d_exp(a) == 0x7ffu && ((a.y & 0xfffffu) | a.x) == 0u;
}

fn gbuf_d_is_zero(a: vec2<u32>) -> bool {
    // Zero, or a subnormal (never produced here; read as zero).
    return gbuf_d_exp(a) == 0u;
}

const GBUF_D_NAN: vec2<u32> = vec2<u32>(0u, 0x7ff80000u);

fn gbuf_d_inf(sign: u32) -> vec2<u32> {
    return vec2<u32>(0u, sign | 0x7ff00000u);
}

// Round a significand m (leading one at bit 63) of value m · 2^(e − 1023 − 63) to nearest even and pack it.
fn gbuf_d_pack(sign: u32, e_in: i32, m: vec2<u32>) -> vec2<u32> {
    var e = e_in;
    var keep = gbuf_shr64(m, 11u);
    let round = (m.x >> 10u) & 1u;
    let sticky = (m.x & 0x3ffu) != 0u;
    if (round == 1u && (sticky || (keep.x & 1u) == 1u)) {
        keep = gbuf_add64(keep, vec2<u32>(1u, 0u));
        if (keep.y >= 0x200000u) {
            keep = gbuf_shr64(keep, 1u);
            e = e + 1;
        }
    }
    if (e >= 2047) {
        return gbuf_d_inf(sign);
    }
    if (e <= 0) {
        return vec2<u32>(0u, sign);
    }
    return vec2<u32>(keep.x, sign | (u32(e) << 20u) | (keep.y & 0xfffffu));
}

// An integer magnitude times 2^scale, exactly (it has at most 32 bits).
fn gbuf_d_from_scaled(sign: u32, mag: u32, scale: i32) -> vec2<u32> {
    if (mag == 0u) {
        return vec2<u32>(0u, sign);
    }
    let lz = countLeadingZeros(mag);
    // mag << (32 + lz) puts the leading one at bit 63 of a 64-bit significand.
    let m = vec2<u32>(0u, mag << lz);
    return gbuf_d_pack(sign, scale + 1023 + 31 - i32(lz), m);
}

fn gbuf_d_from_f32(v: f32) -> vec2<u32> {
    let b = bitcast<u32>(v);
    let sign = b & 0x80000000u;
    let e = (b >> 23u) & 0xffu;
    let f = b & 0x7fffffu;
    if (e == 0xffu) {
        return select(gbuf_d_inf(sign), GBUF_D_NAN, f != 0u);
    }
    if (e == 0u) {
        return gbuf_d_from_scaled(sign, f, -149);
    }
    return gbuf_d_from_scaled(sign, f | 0x800000u, i32(e) - 150);
}

fn gbuf_d_from_i32(v: i32) -> vec2<u32> {
    let u = bitcast<u32>(v);
    let neg = v < 0;
    return gbuf_d_from_scaled(select(0u, 0x80000000u, neg), select(u, 0u - u, neg), 0);
}

fn gbuf_d_from_u32(v: u32) -> vec2<u32> {
    return gbuf_d_from_scaled(0u, v, 0);
}

// To the nearest single, ties to even (Rust's `as f32`), subnormal singles included.
fn gbuf_d_to_f32(a: vec2<u32>) -> f32 {
    let sign = a.y & 0x80000000u;
    let e = i32(gbuf_d_exp(a));
    if (gbuf_d_is_nan(a)) {
        return bitcast<f32>(0x7fc00000u);
    }
    if (e == 0x7ff) {
        return bitcast<f32>(sign | 0x7f800000u);
    }
    if (e == 0) {
        return bitcast<f32>(sign);
    }
    let fe = e - 1023 + 127;
    if (fe >= 255) {
        return bitcast<f32>(sign | 0x7f800000u);
    }
    let m = gbuf_d_sig(a);
    // Bits of the 53-bit significand below the single's: 29 for a normal result, more for a subnormal one.
    let shift = u32(select(29, 29 + 1 - fe, fe < 1));
    if (shift > 54u) {
        return bitcast<f32>(sign);
    }
    var keep = gbuf_shr64(m, shift);
    let rest = gbuf_sub64(m, gbuf_shl64(keep, shift));
    let half = gbuf_shl64(vec2<u32>(1u, 0u), shift - 1u);
    if (gbuf_lt64(half, rest) || (rest.x == half.x && rest.y == half.y && (keep.x & 1u) == 1u)) {
        keep.x = keep.x + 1u;
    }
    if (fe < 1) {
        // A subnormal single (keep < 2^23), or the smallest normal one after rounding (keep = 2^23).
        return bitcast<f32>(sign | keep.x);
    }
    // keep ∈ [2^23, 2^24]; 2^24 carried into the next binade, which the exponent field absorbs by addition.
    let bits = (u32(fe) << 23u) + (keep.x - 0x800000u);
    return bitcast<f32>(sign | select(bits, 0x7f800000u, bits >= 0x7f800000u));
}

fn gbuf_d_neg(a: vec2<u32>) -> vec2<u32> {
    return vec2<u32>(a.x, a.y ^ 0x80000000u);
}

fn gbuf_d_add(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    if (gbuf_d_is_nan(a) || gbuf_d_is_nan(b)) {
        return GBUF_D_NAN;
    }
    if (gbuf_d_is_inf(a)) {
        return select(a, GBUF_D_NAN, gbuf_d_is_inf(b) && (a.y ^ b.y) >= 0x80000000u);
    }
    if (gbuf_d_is_inf(b)) {
        return b;
    }
    if (gbuf_d_is_zero(b)) {
        // x + 0 = x; −0 + +0 = +0.
        return select(a, vec2<u32>(0u, a.y & b.y & 0x80000000u), gbuf_d_is_zero(a));
    }
    if (gbuf_d_is_zero(a)) {
        return b;
    }
    // |x| ≥ |y|.
    let a_mag = vec2<u32>(a.x, a.y & 0x7fffffffu);
    let b_mag = vec2<u32>(b.x, b.y & 0x7fffffffu);
    var x = a;
    var y = b;
    if (gbuf_lt64(a_mag, b_mag)) {
        x = b;
        y = a;
    }
    let ex = gbuf_d_exp(x);
    let ey = gbuf_d_exp(y);
    // Leading ones at bit 62, a bit of headroom for the carry.
    let mx = gbuf_shl64(gbuf_d_sig(x), 10u);
    let my = gbuf_shr64_sticky(gbuf_shl64(gbuf_d_sig(y), 10u), ex - ey);
    let sign = x.y & 0x80000000u;
    var m: vec2<u32>;
    if (((x.y ^ y.y) & 0x80000000u) == 0u) {
        m = gbuf_add64(mx, my);
    } else {
        m = gbuf_sub64(mx, my);
        if ((m.x | m.y) == 0u) {
            return vec2<u32>(0u, 0u);
        }
    }
    let lz = gbuf_clz64(m);
    return gbuf_d_pack(sign, i32(ex) + 1 - i32(lz), gbuf_shl64(m, lz));
}

fn gbuf_d_sub(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    return gbuf_d_add(a, gbuf_d_neg(b));
}

fn gbuf_d_mul(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let sign = (a.y ^ b.y) & 0x80000000u;
    if (gbuf_d_is_nan(a) || gbuf_d_is_nan(b)) {
        return GBUF_D_NAN;
    }
    if (gbuf_d_is_inf(a) || gbuf_d_is_inf(b)) {
        return select(gbuf_d_inf(sign), GBUF_D_NAN, gbuf_d_is_zero(a) || gbuf_d_is_zero(b));
    }
    if (gbuf_d_is_zero(a) || gbuf_d_is_zero(b)) {
        return vec2<u32>(0u, sign);
    }
    // Significands with their leading ones at bit 63: the 128-bit product has its leading one at bit 126 or 127.
    let x = gbuf_shl64(gbuf_d_sig(a), 11u);
    let y = gbuf_shl64(gbuf_d_sig(b), 11u);
    let p00 = gbuf_mul32(x.x, y.x);
    let p01 = gbuf_mul32(x.x, y.y);
    let p10 = gbuf_mul32(x.y, y.x);
    let p11 = gbuf_mul32(x.y, y.y);
    let s1a = gbuf_adc(p00.y, p01.x);
    let s1 = gbuf_adc(s1a.x, p10.x);
    let c1 = s1a.y + s1.y;
    let s2a = gbuf_adc(p01.y, p10.y);
    let s2b = gbuf_adc(s2a.x, p11.x);
    let s2 = gbuf_adc(s2b.x, c1);
    let r3 = p11.y + s2a.y + s2b.y + s2.y;
    var hi = vec2<u32>(s2.x, r3);
    var lo = vec2<u32>(p00.x, s1.x);
    var e = i32(gbuf_d_exp(a)) + i32(gbuf_d_exp(b)) - 1022;
    if (r3 < 0x80000000u) {
        hi = vec2<u32>(hi.x << 1u, (hi.y << 1u) | (hi.x >> 31u));
        hi.x = hi.x | (lo.y >> 31u);
        lo = vec2<u32>(lo.x << 1u, (lo.y << 1u) | (lo.x >> 31u));
        e = e - 1;
    }
    hi.x = hi.x | select(0u, 1u, (lo.x | lo.y) != 0u);
    return gbuf_d_pack(sign, e, hi);
}

fn gbuf_d_div(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let sign = (a.y ^ b.y) & 0x80000000u;
    if (gbuf_d_is_nan(a) || gbuf_d_is_nan(b) || (gbuf_d_is_inf(a) && gbuf_d_is_inf(b))
        || (gbuf_d_is_zero(a) && gbuf_d_is_zero(b))) {
        return GBUF_D_NAN;
    }
    if (gbuf_d_is_inf(a) || gbuf_d_is_zero(b)) {
        return gbuf_d_inf(sign);
    }
    if (gbuf_d_is_inf(b) || gbuf_d_is_zero(a)) {
        return vec2<u32>(0u, sign);
    }
    let d = gbuf_d_sig(b);
    var r = gbuf_d_sig(a);
    var e = i32(gbuf_d_exp(a)) - i32(gbuf_d_exp(b)) + 1023;
    if (gbuf_lt64(r, d)) {
        r = gbuf_shl64(r, 1u);
        e = e - 1;
    }
    // Long division: 55 quotient bits (53, the round bit and one more), then the remainder as the sticky bit.
    var q = vec2<u32>(0u, 0u);
    for (var i = 0u; i < 55u; i++) {
        q = gbuf_shl64(q, 1u);
        if (!gbuf_lt64(r, d)) {
            r = gbuf_sub64(r, d);
            q.x = q.x | 1u;
        }
        r = gbuf_shl64(r, 1u);
    }
    var m = gbuf_shl64(q, 9u);
    m.x = m.x | select(0u, 1u, (r.x | r.y) != 0u);
    return gbuf_d_pack(sign, e, m);
}

// a < b for non-NaN doubles (−0 = +0).
fn gbuf_d_lt(a: vec2<u32>, b: vec2<u32>) -> bool {
    if (gbuf_d_is_zero(a) && gbuf_d_is_zero(b)) {
        return false;
    }
    let na = a.y >= 0x80000000u;
    let nb = b.y >= 0x80000000u;
    let ma = vec2<u32>(a.x, a.y & 0x7fffffffu);
    let mb = vec2<u32>(b.x, b.y & 0x7fffffffu);
    if (na != nb) {
        return na;
    }
    return select(gbuf_lt64(ma, mb), gbuf_lt64(mb, ma), na);
}

fn gbuf_d_clamp(v: vec2<u32>, lo: vec2<u32>, hi: vec2<u32>) -> vec2<u32> {
    return select(select(v, hi, gbuf_d_lt(hi, v)), lo, gbuf_d_lt(v, lo));
}

fn gbuf_d_max(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    return select(a, b, gbuf_d_lt(a, b));
}

// Round half away from zero of a value clamped to ±2^24 (NaN → 0): gbuf's rule for codes.
fn gbuf_d_round(v: vec2<u32>) -> i32 {
    if (gbuf_d_is_nan(v)) {
        return 0;
    }
    let neg = v.y >= 0x80000000u;
    let e = i32(gbuf_d_exp(v));
    var mag: u32;
    if (e >= 1023 + 24) {
        mag = 16777216u;
    } else if (e < 1022) {
        mag = 0u;
    } else {
        // ⌊2·|v|⌋, then half of it rounded up: halves go away from zero.
        let twice = gbuf_shr64(gbuf_d_sig(v), u32(1074 - e));
        mag = (twice.x + 1u) >> 1u;
    }
    return select(i32(mag), -i32(mag), neg);
}
