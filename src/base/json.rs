//! Reading back what JSON cannot hold: serde_json writes NaN and ±∞ as `null`.

/// Deserializes an `f64` that JSON may hold as `null` (serde_json writes NaN and ±∞ as `null`): `null` reads back
/// as NaN, so a report written with a non-finite number still reads back (`gbuf merge`). Use with
/// `#[serde(deserialize_with = "crate::base::json::f64_or_nan")]`.
pub fn f64_or_nan<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    use serde::Deserialize;
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}
