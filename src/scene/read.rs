//! Reading scene text: every problem of the JSON layer in the scene's own words.
//!
//! ```text
//! bytes      a UTF-8 byte-order mark is skipped; invalid UTF-8 is reported with its byte offset
//! syntax     serde_json's syntax error with line and column (one problem: nothing after it
//!            can be read)
//! keys       a key given twice in one object is an error naming both places (serde_json would
//!            silently keep the last one)
//! fields     every element of every list is read on its own, and inside an element an unknown
//!            field or a wrong type is reported and then removed, so one run lists them all
//! words      no Rust type names: "expected usize" reads "expected a whole number >= 0",
//!            "untagged enum NodeRef" reads "must be a list of node indices or a node-set
//!            name"; every echoed value is cut to about 80 characters
//! ```

use super::{Problem, Scene};
use serde::de::DeserializeOwned;
use serde_json::Value;

/// Longest run of characters without a space that a message echoes whole.
pub const ECHO_LIMIT: usize = 80;
/// Longest message (path included) a problem prints.
pub const MESSAGE_LIMIT: usize = 600;
/// At most this many problems are listed per list element (the rest follow from the first).
const PER_ELEMENT: usize = 16;

/// Text that is not UTF-8: where its first invalid byte is (after any byte-order mark).
#[derive(Clone, Debug, PartialEq)]
pub struct NotUtf8 {
    /// Byte offset of the first invalid byte.
    pub offset: usize,
    /// Its 1-based line.
    pub line: usize,
    pub byte: u8,
}

impl std::fmt::Display for NotUtf8 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "not valid UTF-8: byte offset {} (line {}) starts invalid UTF-8 (byte 0x{:02X}); save the file as UTF-8",
            self.offset, self.line, self.byte
        )
    }
}

/// Decode scene or load-table bytes: skip a byte-order mark, name the offset of invalid UTF-8.
pub fn decode_text(bytes: &[u8]) -> Result<&str, NotUtf8> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    std::str::from_utf8(bytes).map_err(|e| {
        let offset = e.valid_up_to();
        NotUtf8 {
            offset,
            line: 1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count(),
            byte: bytes[offset],
        }
    })
}

/// Parse scene bytes into a scene, or list every problem found at the JSON level. The second
/// value is the scene read without the unknown fields when they were the only problems (so
/// `velarium check` can go on to the semantic checks in the same run).
#[allow(clippy::result_large_err)] // once per scene read; the error carries what could be read
pub fn parse(bytes: &[u8]) -> Result<Scene, (Vec<Problem>, Option<Scene>)> {
    let text = decode_text(bytes).map_err(|e| (vec![problem("", e.to_string())], None))?;
    let mut value: Value = serde_json::from_str(text).map_err(|e| {
        let m = e.to_string();
        (
            vec![problem("", format!("invalid JSON: {}", words(&m)))],
            None,
        )
    })?;
    let mut problems = duplicate_keys(text);
    let mut only_unknown = true;
    collect_scene(&mut value, &mut problems, &mut only_unknown);
    if problems.is_empty() {
        return serde_json::from_value::<Scene>(value)
            .map_err(|e| (vec![problem("", words(&e.to_string()))], None::<Scene>));
    }
    let recovered = if only_unknown && !problems.iter().any(|p| p.message.contains("twice")) {
        serde_json::from_value::<Scene>(value).ok()
    } else {
        None
    };
    Err((problems, recovered))
}

impl Scene {
    /// Parse a scene from JSON text; the first problem found (see [`Scene::parse`]).
    pub fn from_json(text: &str) -> Result<Scene, Problem> {
        Scene::parse(text.as_bytes()).map_err(|mut p| p.swap_remove(0))
    }

    /// Parse scene bytes (a UTF-8 byte-order mark is skipped). Every problem of the JSON layer
    /// is listed with its path: syntax, invalid UTF-8 (by byte offset), keys given twice,
    /// unknown fields and wrong types (see the module doc).
    pub fn parse(bytes: &[u8]) -> Result<Scene, Vec<Problem>> {
        parse(bytes).map_err(|(problems, _)| problems)
    }
}

impl std::fmt::Display for Problem {
    /// `path: message`, every echoed value cut to about 80 characters ([`clip`]).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.path.is_empty() {
            write!(f, "{}", clip(&self.message))
        } else {
            write!(f, "{}", clip(&format!("{}: {}", self.path, self.message)))
        }
    }
}

fn problem(path: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem {
        path: path.into(),
        message: message.into(),
    }
}

/// The scene's top-level sections, each list element read on its own.
fn collect_scene(v: &mut Value, out: &mut Vec<Problem>, only_unknown: &mut bool) {
    let Some(obj) = v.as_object_mut() else {
        out.push(problem(
            "",
            format!("a scene must be a JSON object, not {}", kind_of(v)),
        ));
        *only_unknown = false;
        return;
    };
    macro_rules! list {
        ($key:literal, $t:ty) => {
            if let Some(Value::Array(items)) = obj.get_mut($key) {
                for (i, item) in items.iter_mut().enumerate() {
                    element::<$t>(item, &format!("{}[{i}]", $key), out, only_unknown);
                }
            }
        };
    }
    list!("membranes", super::Membrane);
    list!("cables", super::Cable);
    list!("supports", super::Support);
    list!("inputs", super::Input);
    list!("outputs", super::Output);
    list!("parameters", super::Parameter);
    if let Some(Value::Object(g)) = obj.get_mut("geometry") {
        if let Some(Value::Array(items)) = g.get_mut("generators") {
            for (i, item) in items.iter_mut().enumerate() {
                let p = format!("geometry.generators[{i}]");
                element::<super::Generator>(item, &p, out, only_unknown);
            }
        }
        if let Some(Value::Array(items)) = g.get_mut("triangles") {
            for (i, item) in items.iter_mut().enumerate() {
                let p = format!("geometry.triangles[{i}]");
                element::<[super::OneNode; 3]>(item, &p, out, only_unknown);
            }
        }
        if let Some(Value::Array(items)) = g.get_mut("nodes") {
            for (i, item) in items.iter_mut().enumerate() {
                element::<[f64; 3]>(item, &format!("geometry.nodes[{i}]"), out, only_unknown);
            }
        }
    }
    for key in ["solver", "experiment", "debug"] {
        if obj.contains_key(key) {
            let mut section = obj.remove(key).expect("present");
            match key {
                "solver" => element::<super::SolverSettings>(&mut section, key, out, only_unknown),
                "experiment" => element::<super::Experiment>(&mut section, key, out, only_unknown),
                _ => element::<super::DebugSettings>(&mut section, key, out, only_unknown),
            }
            obj.insert(key.to_string(), section);
        }
    }
    // What remains (top-level fields, geometry's own fields, list shapes): a skeleton of the
    // scene with the lists and sections already checked emptied.
    let mut skeleton = serde_json::Map::new();
    for (key, x) in v.as_object().expect("an object") {
        let x = match (key.as_str(), x) {
            ("geometry", Value::Object(g)) => Value::Object(
                g.iter()
                    .map(|(k, y)| match (k.as_str(), y) {
                        ("generators" | "triangles" | "nodes", Value::Array(_)) => {
                            (k.clone(), Value::Array(Vec::new()))
                        }
                        _ => (k.clone(), y.clone()),
                    })
                    .collect(),
            ),
            (_, Value::Array(_)) => Value::Array(Vec::new()),
            ("solver" | "experiment" | "debug", Value::Object(_)) => {
                Value::Object(Default::default())
            }
            _ => x.clone(),
        };
        skeleton.insert(key.clone(), x);
    }
    // The two required top-level fields, each named when missing (serde stops at the first);
    // a stand-in lets the rest of the skeleton be read.
    for (key, what, stand_in) in [
        (
            "format",
            "the scene format version, 1 in this build",
            Value::from(super::FORMAT_VERSION),
        ),
        (
            "name",
            "the model name, a C identifier (letters, digits, _) that names the FMU and its library",
            Value::from("_"),
        ),
    ] {
        if !skeleton.contains_key(key) {
            out.push(problem(key, format!("missing: a scene needs \"{key}\", {what}")));
            *only_unknown = false;
            skeleton.insert(key.to_string(), stand_in);
        }
    }
    let mut skeleton = Value::Object(skeleton);
    let before = out.len();
    element::<Scene>(&mut skeleton, "", out, only_unknown);
    // Unknown top-level fields are removed from the scene itself too.
    for p in &out[before..] {
        if p.message.starts_with("unknown field") && !p.path.contains('[') {
            remove(v, &p.path);
        }
    }
}

/// Read `v` as a `T`. On failure record the problem at its path; an unknown field or a field of
/// the wrong type is then removed and the element read again, so that every problem of the
/// element is listed. Returns once the element reads or a problem cannot be removed.
fn element<T: DeserializeOwned>(
    v: &mut Value,
    path: &str,
    out: &mut Vec<Problem>,
    only_unknown: &mut bool,
) {
    for _ in 0..PER_ELEMENT {
        let err = match serde_path_to_error::deserialize::<_, T>(&*v) {
            Ok(_) => return,
            Err(e) => e,
        };
        let inner = err.path().to_string();
        let inner = if inner == "." { String::new() } else { inner };
        let raw = err.into_inner().to_string();
        // Internally tagged enums (generators, materials, loads, probes) lose the path inside
        // them: find the field the message is about.
        let at = locate(v, &inner, &raw);
        let full = join(path, &at);
        let unknown = raw.starts_with("unknown field");
        if let Some(field) = raw
            .strip_prefix("missing field `")
            .and_then(|r| r.split('`').next())
        {
            // A field removed after its own problem is reported only once.
            let missing = join(&full, field);
            if out.iter().any(|p| {
                p.path == missing
                    || p.path.starts_with(&format!("{missing}["))
                    || p.path.starts_with(&format!("{missing}."))
            }) {
                return;
            }
        }
        if out
            .iter()
            .any(|p| p.path == full && p.message == message(&raw, &full))
        {
            return; // an element already checked on its own, met again inside its parent
        }
        let key = if unknown {
            raw.strip_prefix("unknown field `")
                .and_then(|r| r.split('`').next())
                .map(|k| {
                    // serde_path_to_error's path may already end at the unknown key.
                    if at == k || at.ends_with(&format!(".{k}")) {
                        at.clone()
                    } else {
                        join(&at, k)
                    }
                })
        } else {
            // A wrong list item: remove the whole field (its problem is reported once).
            let mut k = at.as_str();
            while k.ends_with(']') {
                k = k.rfind('[').map_or("", |i| &k[..i]);
            }
            Some(k.to_string())
        };
        let shown = match (&key, unknown) {
            (Some(k), true) => join(path, k),
            _ => full.clone(),
        };
        out.push(problem(shown, message(&raw, &full)));
        *only_unknown &= unknown;
        if !key.filter(|k| !k.is_empty()).is_some_and(|k| remove(v, &k)) {
            return;
        }
    }
}

fn join(a: &str, b: &str) -> String {
    match (a.is_empty(), b.is_empty()) {
        (true, _) => b.to_string(),
        (_, true) => a.to_string(),
        _ if b.starts_with('[') => format!("{a}{b}"),
        _ => format!("{a}.{b}"),
    }
}

/// Split a path such as `probe.node` or `nodes[2]` into steps.
fn steps(path: &str) -> Vec<Step> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let mut rest = part;
        if let Some(i) = rest.find('[') {
            if i > 0 {
                out.push(Step::Key(rest[..i].to_string()));
            }
            rest = &rest[i..];
            while let Some(end) = rest.find(']') {
                match rest[1..end].parse() {
                    Ok(n) => out.push(Step::Index(n)),
                    Err(_) => out.push(Step::Key(rest[1..end].to_string())),
                }
                rest = &rest[end + 1..];
            }
        } else {
            out.push(Step::Key(rest.to_string()));
        }
    }
    out
}

enum Step {
    Key(String),
    Index(usize),
}

fn get<'a>(v: &'a Value, path: &str) -> Option<&'a Value> {
    steps(path).iter().try_fold(v, |v, s| match s {
        Step::Key(k) => v.get(k),
        Step::Index(i) => v.get(i),
    })
}

/// Remove the field at `path` (a key of an object); false if it is not a removable field.
fn remove(v: &mut Value, path: &str) -> bool {
    let mut steps = steps(path);
    let Some(Step::Key(last)) = steps.pop() else {
        return false;
    };
    let mut cur = v;
    for s in &steps {
        cur = match s {
            Step::Key(k) => match cur.get_mut(k) {
                Some(c) => c,
                None => return false,
            },
            Step::Index(i) => match cur.get_mut(*i) {
                Some(c) => c,
                None => return false,
            },
        };
    }
    cur.as_object_mut()
        .is_some_and(|o| o.remove(&last).is_some())
}

/// The path (relative to the element) a message is about. serde_path_to_error stops at an
/// internally tagged enum; below it the field is found from the message: a named field, an
/// untagged reference, or the one value whose description the message quotes.
fn locate(v: &Value, inner: &str, raw: &str) -> String {
    let Some(here) = get(v, inner) else {
        return inner.to_string();
    };
    if !here.is_object() || raw.starts_with("unknown field") || raw.starts_with("missing field") {
        return inner.to_string();
    }
    if here.get("kind").is_none() {
        return inner.to_string();
    }
    if let Some(kind) = untagged_kind(raw) {
        let fields: &[&str] = match kind {
            "NodeRef" => &["nodes"],
            "OneNode" => &["node", "from", "to"],
            _ => &["triangles"],
        };
        for f in fields {
            if let Some(x) = here.get(*f) {
                if !reads_as(kind, x) {
                    return join(inner, f);
                }
            }
        }
        return inner.to_string();
    }
    if let Some(quoted) = unexpected_part(raw) {
        if let Some(p) = find_value(here, &quoted, String::new()) {
            return join(inner, &p);
        }
    }
    if let Some(len) = raw
        .strip_prefix("invalid length ")
        .and_then(|r| r.split(',').next())
        .and_then(|n| n.parse::<usize>().ok())
    {
        if let Some(obj) = here.as_object() {
            let hits: Vec<&String> = obj
                .iter()
                .filter(|(_, x)| x.as_array().is_some_and(|a| a.len() == len))
                .map(|(k, _)| k)
                .collect();
            if hits.len() == 1 {
                return join(inner, hits[0]);
            }
        }
    }
    inner.to_string()
}

fn reads_as(kind: &str, x: &Value) -> bool {
    match kind {
        "NodeRef" => serde_json::from_value::<super::NodeRef>(x.clone()).is_ok(),
        "OneNode" => serde_json::from_value::<super::OneNode>(x.clone()).is_ok(),
        _ => serde_json::from_value::<super::TriangleRef>(x.clone()).is_ok(),
    }
}

fn untagged_kind(raw: &str) -> Option<&str> {
    raw.strip_prefix("data did not match any variant of untagged enum ")
        .map(|r| r.split_whitespace().next().unwrap_or(""))
}

/// "floating point `1.5`" out of "invalid type: floating point `1.5`, expected usize".
fn unexpected_part(raw: &str) -> Option<String> {
    let rest = raw
        .strip_prefix("invalid type: ")
        .or_else(|| raw.strip_prefix("invalid value: "))?;
    Some(rest.rsplit_once(", expected ")?.0.to_string())
}

/// How serde describes a JSON value in "invalid type" messages.
fn describe(x: &Value) -> String {
    match x {
        Value::Array(_) => "sequence".into(),
        Value::Object(_) => "map".into(),
        _ => serde_json::from_value::<()>(x.clone())
            .err()
            .and_then(|e| unexpected_part(&e.to_string()))
            .unwrap_or_default(),
    }
}

/// Depth-first: the path of the first value described as `quoted`.
fn find_value(x: &Value, quoted: &str, path: String) -> Option<String> {
    match x {
        Value::Object(o) => o
            .iter()
            .filter(|(k, _)| k.as_str() != "kind")
            .find_map(|(k, c)| {
                if describe(c) == quoted {
                    return Some(join(&path, k));
                }
                find_value(c, quoted, join(&path, k))
            }),
        Value::Array(a) => a.iter().take(10_000).enumerate().find_map(|(i, c)| {
            if describe(c) == quoted {
                return Some(format!("{path}[{i}]"));
            }
            find_value(c, quoted, format!("{path}[{i}]"))
        }),
        _ => None,
    }
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

/// The message of a serde error at `path`, in the scene's words.
fn message(raw: &str, path: &str) -> String {
    if let Some(kind) = untagged_kind(raw) {
        return match kind {
            "NodeRef" => "must be a list of node indices or a node-set name".into(),
            "OneNode" => "must be a node index or the name of a one-node set".into(),
            "TriangleRef" => "must be a list of triangle indices or a triangle-set name".into(),
            _ => "has the wrong form".into(),
        };
    }
    if raw.contains("expected internally tagged enum") {
        let what = path.rsplit('.').next().unwrap_or(path);
        return format!(
            "must be an object with a \"kind\" field ({what} {})",
            raw.split(", expected")
                .next()
                .unwrap_or(raw)
                .replace("invalid type: ", "given: ")
        );
    }
    words(raw)
}

/// Replace Rust and serde vocabulary in a message with the scene's words.
pub fn words(raw: &str) -> String {
    let mut m = raw.to_string();
    for (from, to) in [
        ("expected usize", "expected a whole number >= 0"),
        ("expected u64", "expected a whole number >= 0"),
        ("expected u32", "expected a whole number >= 0"),
        ("expected u8", "expected a whole number >= 0"),
        ("expected f64", "expected a number"),
        ("expected a sequence", "expected a list"),
        ("expected a map", "expected an object"),
        ("expected a boolean", "expected true or false"),
        ("expected unit", "expected null"),
        (
            "expected string or map",
            "expected one of the documented names",
        ),
        ("expected variant identifier", "expected a kind name"),
        ("expected `kind`", "expected a \"kind\" field"),
        ("invalid type: sequence", "invalid type: a list"),
        ("invalid type: map", "invalid type: an object"),
        ("invalid type: unit value", "invalid type: null"),
        ("an array of length", "a list of length"),
        ("array of length", "list of length"),
        ("a tuple of size", "a list of length"),
    ] {
        m = m.replace(from, to);
    }
    // "expected struct Cable" and the like.
    while let Some(at) = m.find("expected struct ") {
        let end = m[at + 16..]
            .find(|c: char| !c.is_alphanumeric())
            .map_or(m.len(), |e| at + 16 + e);
        m.replace_range(at..end, "expected an object");
    }
    while let Some(at) = m.find("expected enum ") {
        let end = m[at + 14..]
            .find(|c: char| !c.is_alphanumeric())
            .map_or(m.len(), |e| at + 14 + e);
        m.replace_range(at..end, "expected one of the documented names");
    }
    m
}

/// Cut every run of more than [`ECHO_LIMIT`] characters without a space, and the whole text
/// to [`MESSAGE_LIMIT`] characters, so that a hostile value is never echoed whole.
pub fn clip(text: &str) -> String {
    let mut out = String::new();
    for (i, word) in text.split(' ').enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let n = word.chars().count();
        if n > ECHO_LIMIT {
            out.extend(word.chars().take(ECHO_LIMIT - 20));
            out.push_str(&format!("…({n} characters)"));
        } else {
            out.push_str(word);
        }
    }
    let n = out.chars().count();
    if n > MESSAGE_LIMIT {
        let mut cut: String = out.chars().take(MESSAGE_LIMIT - 30).collect();
        cut.push_str(&format!("…({n} characters in all)"));
        return cut;
    }
    out
}

/// Every key given twice in one JSON object, naming the object's path and both places.
/// `text` is valid JSON (serde_json read it).
pub fn duplicate_keys(text: &str) -> Vec<Problem> {
    enum Frame {
        Object {
            path: String,
            keys: std::collections::HashMap<String, (usize, usize)>,
            key: Option<String>,
        },
        Array {
            path: String,
            index: usize,
        },
    }
    fn child(stack: &[Frame]) -> String {
        match stack.last() {
            None => String::new(),
            Some(Frame::Object { path, key, .. }) => join(path, key.as_deref().unwrap_or("")),
            Some(Frame::Array { path, index }) => format!("{path}[{index}]"),
        }
    }
    let mut out = Vec::new();
    let mut stack: Vec<Frame> = Vec::new();
    let b = text.as_bytes();
    let (mut i, mut line, mut line_start) = (0usize, 1usize, 0usize);
    // After a string inside an object: is it a key (followed by ':')?
    let mut expect_key = false;
    while i < b.len() {
        match b[i] {
            b'\n' => {
                line += 1;
                line_start = i + 1;
            }
            b'{' => {
                let path = child(&stack);
                stack.push(Frame::Object {
                    path,
                    keys: Default::default(),
                    key: None,
                });
                expect_key = true;
            }
            b'[' => {
                let path = child(&stack);
                stack.push(Frame::Array { path, index: 0 });
                expect_key = false;
            }
            b'}' | b']' => {
                stack.pop();
                expect_key = false;
            }
            b',' => match stack.last_mut() {
                Some(Frame::Array { index, .. }) => *index += 1,
                Some(Frame::Object { .. }) => expect_key = true,
                None => {}
            },
            b'"' => {
                let start = i;
                i += 1;
                let mut escaped = false;
                while i < b.len() && b[i] != b'"' {
                    if b[i] == b'\\' {
                        escaped = true;
                        i += 1;
                    }
                    i += 1;
                }
                if expect_key {
                    let raw = &text[start..=i.min(b.len() - 1)];
                    let name = if escaped {
                        serde_json::from_str::<String>(raw).unwrap_or_else(|_| raw.to_string())
                    } else {
                        raw[1..raw.len() - 1].to_string()
                    };
                    let column = text[line_start..start].chars().count() + 1;
                    if let Some(Frame::Object { path, keys, key }) = stack.last_mut() {
                        if let Some((l0, c0)) = keys.get(&name) {
                            out.push(problem(
                                join(path, &name),
                                format!(
                                    "the key \"{name}\" is given twice in this object (line {l0}, column {c0} and line {line}, column {column}); remove one of them"
                                ),
                            ));
                        } else {
                            keys.insert(name.clone(), (line, column));
                        }
                        *key = Some(name);
                    }
                    expect_key = false;
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_are_found_with_both_places() {
        let p = duplicate_keys(
            "{\"a\": {\"m\": [1], \"n\": 2,\n \"m\": [0]}, \"b\": [{\"x\": 1, \"x\": 2}]}",
        );
        assert_eq!(p.len(), 2, "{p:?}");
        assert_eq!(p[0].path, "a.m");
        assert!(
            p[0].message
                .contains("line 1, column 8 and line 2, column 2"),
            "{}",
            p[0]
        );
        assert_eq!(p[1].path, "b[0].x");
        assert!(duplicate_keys(r#"{"a": "{\"a\": 1, \"a\": 2}", "b": {"a": 1}}"#).is_empty());
    }

    #[test]
    fn clip_cuts_long_words() {
        let long = "x".repeat(100_000);
        let c = clip(&format!("name \"{long}\" is bad"));
        assert!(c.len() < 200, "{c}");
        assert!(c.contains("100002 characters"), "{c}");
    }
}
