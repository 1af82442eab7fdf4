//! The FMI 2 resource location: a percent-encoded `file:` URI (RFC 8089).
//!
//! ```text
//! file:///a/b%20c/%C3%A4      -> /a/b c/ä      (fmpy: pathlib.Path.as_uri())
//! file:/a/b                   -> /a/b          (the short form some masters pass)
//! file://localhost/a/b        -> /a/b
//! file://server/a/b           -> error (not a local file)
//! ```
//!
//! `%XX` sequences are decoded to bytes before the path is built, so multi-byte UTF-8 (and any
//! other byte a Unix path may hold) survives; a malformed escape is an error, never a guess.

use crate::error::Error;
use std::path::PathBuf;

/// The local directory a `file:` URI names (Err: [`Error::ResourceUri`]).
pub fn file_uri_to_path(uri: &str) -> Result<PathBuf, Error> {
    let bad = |why: String| Error::ResourceUri {
        uri: uri.to_string(),
        why,
    };
    let rest = strip_scheme(uri).ok_or_else(|| bad("is not a file: URI".into()))?;
    let path = match rest.strip_prefix("//") {
        None => rest,
        Some(authority_and_path) => {
            let (host, path) = authority_and_path.split_at(
                authority_and_path
                    .find('/')
                    .unwrap_or(authority_and_path.len()),
            );
            if !host.is_empty() && !host.eq_ignore_ascii_case("localhost") {
                return Err(bad(format!(
                    "names host \"{host}\"; only local files can be read"
                )));
            }
            path
        }
    };
    if !path.starts_with('/') {
        return Err(bad("does not hold an absolute path".into()));
    }
    let bytes = percent_decode(path).map_err(|escape| {
        bad(format!(
            "holds \"%{}\", which is not a percent escape ('%' and two hex digits)",
            String::from_utf8_lossy(escape)
        ))
    })?;
    Ok(bytes_to_path(bytes))
}

/// The part after `file:` (scheme names are case-insensitive).
fn strip_scheme(uri: &str) -> Option<&str> {
    let (scheme, rest) = uri.split_once(':')?;
    scheme.eq_ignore_ascii_case("file").then_some(rest)
}

/// Decode `%XX` escapes to bytes (Err: what follows a '%' that is not two hex digits).
fn percent_decode(text: &str) -> Result<Vec<u8>, &[u8]> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = &bytes[i + 1..(i + 3).min(bytes.len())];
            let value = std::str::from_utf8(hex)
                .ok()
                // Two hex digits exactly (from_str_radix alone would take "+1").
                .filter(|h| h.len() == 2 && h.bytes().all(|b| b.is_ascii_hexdigit()))
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or(hex)?;
            out.push(value);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Ok(out)
}

#[cfg(unix)]
fn bytes_to_path(bytes: Vec<u8>) -> PathBuf {
    use std::os::unix::ffi::OsStringExt;
    PathBuf::from(std::ffi::OsString::from_vec(bytes))
}

#[cfg(not(unix))]
fn bytes_to_path(bytes: Vec<u8>) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(&bytes).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_spaces_and_utf8() {
        let p = file_uri_to_path("file:///tmp/a%20b/%C3%A4/resources").unwrap();
        assert_eq!(p, PathBuf::from("/tmp/a b/ä/resources"));
    }

    #[test]
    fn accepts_the_short_and_localhost_forms() {
        assert_eq!(
            file_uri_to_path("file:/x/y").unwrap(),
            PathBuf::from("/x/y")
        );
        assert_eq!(
            file_uri_to_path("FILE://localhost/x").unwrap(),
            PathBuf::from("/x")
        );
        assert_eq!(
            file_uri_to_path("file:///x%25y").unwrap(),
            PathBuf::from("/x%y")
        );
    }

    #[test]
    fn rejects_what_it_cannot_read() {
        assert!(file_uri_to_path("/plain/path").is_err());
        assert!(file_uri_to_path("http://x/y").is_err());
        assert!(file_uri_to_path("file://server/share").is_err());
        assert!(file_uri_to_path("file:///a%2").is_err());
        assert!(file_uri_to_path("file:///a%zz").is_err());
        assert!(file_uri_to_path("file:///a%+1").is_err());
        assert!(file_uri_to_path("file:relative").is_err());
    }
}
