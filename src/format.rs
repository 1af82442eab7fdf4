//! Text forms of values shared by every writer (modelDescription.xml, reference and result
//! CSVs, VTK files). A leaf: it imports nothing of the crate, so the writers need not import
//! one another for it.
//!
//! ```text
//! xs_double    f64 -> shortest round-trip text, no trailing ".0"; NaN, INF, -INF (XML, CSV)
//! vtk_double   as xs_double, but nan, inf, -inf (what VTK's ASCII reader takes)
//! csv_quoted   a CSV cell in double quotes, inner quotes doubled
//! ```
//!
//! The output of these functions is compared byte for byte (committed modelDescription.xml
//! files, users' regression artefacts): change none of them lightly.

/// A number as an `xs:double`: Rust's shortest round-trip text without a trailing `.0`
/// (exponent form for very large or small magnitudes), `NaN`, `INF`, `-INF`. Python's `float`
/// reads it back exactly too.
pub fn xs_double(value: f64) -> String {
    if value.is_nan() {
        "NaN".into()
    } else if value.is_infinite() {
        if value > 0.0 { "INF" } else { "-INF" }.into()
    } else {
        let text = format!("{value:?}");
        text.strip_suffix(".0").map(str::to_owned).unwrap_or(text)
    }
}

/// A number for a VTK ASCII `DataArray`: [`xs_double`] for finite values, `nan`, `inf`,
/// `-inf` otherwise (VTK's ASCII reader takes them spelled this way).
pub fn vtk_double(value: f64) -> String {
    if value.is_nan() {
        "nan".to_string()
    } else if value.is_infinite() {
        if value > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        xs_double(value)
    }
}

/// A CSV cell in double quotes, a quote inside it doubled (RFC 4180).
pub fn csv_quoted(text: &str) -> String {
    format!("\"{}\"", text.replace('"', "\"\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_are_xs_doubles() {
        assert_eq!(xs_double(1.0), "1");
        assert_eq!(xs_double(0.1), "0.1");
        assert_eq!(xs_double(1e-9), "1e-9");
        assert_eq!(xs_double(2.1e11), "210000000000");
        assert_eq!(xs_double(1e20), "1e20");
        assert_eq!(xs_double(f64::NAN), "NaN");
        assert_eq!(xs_double(f64::NEG_INFINITY), "-INF");
    }

    #[test]
    fn vtk_spells_non_finite_values_in_lower_case() {
        assert_eq!(vtk_double(-0.5), "-0.5");
        assert_eq!(vtk_double(3.0), "3");
        assert_eq!(vtk_double(f64::NAN), "nan");
        assert_eq!(vtk_double(f64::INFINITY), "inf");
        assert_eq!(vtk_double(f64::NEG_INFINITY), "-inf");
    }

    #[test]
    fn csv_cells_double_their_quotes() {
        assert_eq!(csv_quoted("time"), "\"time\"");
        assert_eq!(csv_quoted("a \"b\", c"), "\"a \"\"b\"\", c\"");
    }
}
