//! Integer phase arithmetic shared by both paths and the measurement: phase units of
//! 2π/65 536 (wrapping is a cast to `i16`), and an integer `atan2` over a 257-entry table.
//!
//! `atan2` reduces to the first octant, divides once (Q16 ratio), and interpolates the
//! table: error below 2·10⁻⁵ rad.

/// Phase units per radian in the integer representation (65 536 per turn).
pub const UNITS_PER_RAD: f32 = 65_536.0 / std::f32::consts::TAU;

/// `atan(k/256)` for k = 0…256, in phase units (2π = 65 536), built once.
pub fn atan_table() -> &'static [u16; 257] {
    static TABLE: std::sync::OnceLock<[u16; 257]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            ((k as f64 / 256.0).atan() * 65_536.0 / std::f64::consts::TAU).round() as u16
        })
    })
}

/// Integer `atan2(y, x)` in phase units, in [−32 768, 32 767].
#[inline]
pub fn atan2_units(y: i64, x: i64, table: &[u16; 257]) -> i32 {
    let (ax, ay) = (x.unsigned_abs(), y.unsigned_abs());
    if ax == 0 && ay == 0 {
        return 0;
    }
    let (lo, hi) = if ay > ax { (ay, ax) } else { (ax, ay) };
    // hi / lo in Q16 (≤ 65 536); lo > 0 here. Shift both down to 47 bits first so the
    // 64-bit division cannot overflow.
    let shift = 64 - lo.leading_zeros();
    let (hi, lo) = if shift > 47 {
        (hi >> (shift - 47), (lo >> (shift - 47)).max(1))
    } else {
        (hi, lo)
    };
    let t = ((hi << 16) / lo) as u32;
    let (k, f) = ((t >> 8) as usize, t & 0xff);
    let a0 = u32::from(table[k.min(256)]);
    let a1 = u32::from(table[(k + 1).min(256)]);
    let mut a = (a0 + (((a1 - a0) * f + 128) >> 8)) as i32; // 0 … 8192 (π/4)
    if ay > ax {
        a = 16_384 - a;
    }
    if x < 0 {
        a = 32_768 - a;
    }
    if y < 0 {
        a = -a;
    }
    i32::from(a as i16)
}
