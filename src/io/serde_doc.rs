//! Reading JSON documents through serde document types, every error
//! naming its path (e.g. `blocks[2].a[1][0]`) in the words of the
//! hand-written checks (`expected a number, found string "x"`).

use crate::io::InputError;
use serde::Deserialize;
use serde::de::value::MapAccessDeserializer;
use serde::de::{DeserializeOwned, Deserializer, MapAccess, Visitor};
use serde_json::Value;
use std::fmt;
use std::marker::PhantomData;

/// The top of a document read from `source`.
pub(crate) fn top(source: &str) -> At<'_> {
    At { source, path: "" }
}

/// Parses `text` as a JSON object whose `format` is `format`, for
/// [`from_value`] to read into its document type.
pub(crate) fn parse_object(text: &str, source: &str, format: &str) -> Result<Value, InputError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| InputError::new(source, format!("invalid JSON: {e}")).at_line(e.line()))?;
    let obj = value
        .as_object()
        .ok_or_else(|| InputError::new(source, "expected a JSON object"))?;
    super::tf_json::check_format(obj, source, format)?;
    Ok(value)
}

/// Where an error is: the file, and the path of the field within it.
#[derive(Clone, Copy)]
pub(crate) struct At<'a> {
    pub(crate) source: &'a str,
    pub(crate) path: &'a str,
}

impl At<'_> {
    pub(crate) fn err(&self, key: &str, message: impl Into<String>) -> InputError {
        InputError::new(self.source, message).in_field(join(self.path, key))
    }
}

/// `path.key`, either of them possibly empty.
pub(crate) fn join(path: &str, key: &str) -> String {
    match (path.is_empty(), key.is_empty()) {
        (true, _) => key.to_owned(),
        (false, true) => path.to_owned(),
        (false, false) => format!("{path}.{key}"),
    }
}

/// Deserialises `value` into `T`, an error naming its path below `at`.
pub(crate) fn from_value<T: DeserializeOwned>(value: Value, at: At<'_>) -> Result<T, InputError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let mut path = at.path.to_owned();
        for segment in e.path().iter() {
            use serde_path_to_error::Segment;
            match segment {
                Segment::Seq { index } => path.push_str(&format!("[{index}]")),
                Segment::Map { key } | Segment::Enum { variant: key } => path = join(&path, key),
                Segment::Unknown => path = join(&path, "?"),
            }
        }
        let (key, message) = plain_message(&e.inner().to_string());
        let field = join(&path, &key);
        let e = InputError::new(at.source, message);
        if field.is_empty() {
            e
        } else {
            e.in_field(field)
        }
    })
}

/// serde's message in the words of the other readers (`expected "a" or
/// "b", found "c"`), with the key a missing field error is about split off
/// so it joins the path (the path of an unknown key already ends with it).
fn plain_message(msg: &str) -> (String, String) {
    let backticked = |prefix: &str| {
        let (name, tail) = msg.strip_prefix(prefix)?.split_once('`')?;
        Some((name.to_owned(), quoted(tail.trim_start_matches(", "))))
    };
    if let Some((key, _)) = backticked("missing field `") {
        return (key, "missing".into());
    }
    if let Some((_, tail)) = backticked("unknown field `") {
        return (String::new(), format!("unknown key; {tail}"));
    }
    if let Some((name, expected)) = backticked("unknown variant `") {
        return (String::new(), format!("{expected}, found \"{name}\""));
    }
    if let Some((n, expected)) = msg
        .strip_prefix("invalid length ")
        .and_then(|rest| rest.split_once(", expected "))
    {
        return (
            String::new(),
            format!("expected {expected}, found {n} elements"),
        );
    }
    for prefix in ["invalid type: ", "invalid value: "] {
        if let Some((found, expected)) = msg
            .strip_prefix(prefix)
            .and_then(|rest| rest.rsplit_once(", expected "))
        {
            let (found, expected) = (plain_kind(found), plain_kind(expected));
            return (String::new(), format!("expected {expected}, found {found}"));
        }
    }
    (String::new(), msg.to_owned())
}

/// serde's `a` or `b` as JSON strings, `"a"` or `"b"`.
fn quoted(names: &str) -> String {
    names.replace('`', "\"")
}

/// serde's name of a Rust type or value in JSON's terms.
fn plain_kind(kind: &str) -> String {
    match kind {
        "f64" => "a number".into(),
        "u64" | "usize" => "a non-negative whole number".into(),
        "a sequence" | "sequence" => "an array".into(),
        "map" => "an object".into(),
        k if k.starts_with("struct ") => "an object".into(),
        // `integer `3``, `floating point `4.5``: the value without backticks.
        k => k.replace('`', ""),
    }
}

/// A `T` read from a JSON object only. serde's derived structs also accept
/// an array of their fields in order, which the readers refuse; this reads
/// through the map itself, so errors inside keep their path.
pub(crate) struct Object<T>(pub(crate) T);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Object<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct ObjectVisitor<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for ObjectVisitor<T> {
            type Value = Object<T>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Object<T>, A::Error> {
                T::deserialize(MapAccessDeserializer::new(map)).map(Object)
            }
        }
        d.deserialize_map(ObjectVisitor(PhantomData))
    }
}
