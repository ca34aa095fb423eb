//! Type lookup, REP-2016 type hashes and MCAP `ros2msg` schemas.
//!
//! The hash must be bit-exact with rosidl's, or rmw_zenoh subscribers silently
//! drop our samples, so this mirrors `rosidl_generator_type_description`:
//! the description is `{"type_description": ..., "referenced_type_descriptions": [...]}`
//! with referenced types sorted by name, default values removed, keys in
//! rosidl's order, and Python `json.dumps(separators=(', ', ': '))` spacing.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

use crate::parser::{BaseType, Collection, FieldType, MsgSpec, ParseError, PrimitiveType, TypeRef, parse_msg};

/// A type that a registry cannot resolve.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    #[error("type {name} is not registered")]
    UnknownType { name: String },
    #[error("type {name}, referenced by {referenced_by}, is not registered")]
    MissingDependency { name: String, referenced_by: String },
}

/// rosidl replaces an empty structure by this single member (IDL forbids empty structs).
const EMPTY_STRUCT_MEMBER: &str = "structure_needs_at_least_one_member";

/// A set of parsed `.msg` definitions with their original text.
#[derive(Debug, Clone, Default)]
pub struct Registry {
    /// Keyed by `pkg/msg/Name`, the order rosidl sorts referenced types in.
    types: BTreeMap<String, (MsgSpec, String)>,
}

impl Registry {
    pub fn new() -> Self {
        Self::default()
    }

    /// Parses and adds one `.msg` file; the text is kept verbatim for schemas.
    /// Replaces any earlier definition of the same type.
    pub fn add(&mut self, package: &str, name: &str, text: &str) -> Result<(), ParseError> {
        let spec = parse_msg(&format!("{package}/msg/{name}.msg"), package, name, text)?;
        self.types.insert(spec.type_ref().full_name(), (spec, text.to_owned()));
        Ok(())
    }

    /// Looks a type up by `pkg/msg/Name` or `pkg/Name`.
    pub fn get(&self, type_name: &str) -> Option<&MsgSpec> {
        self.entry(type_name).map(|(spec, _)| spec)
    }

    /// The `.msg` text the type was registered with.
    pub fn text(&self, type_name: &str) -> Option<&str> {
        self.entry(type_name).map(|(_, text)| text.as_str())
    }

    fn entry(&self, type_name: &str) -> Option<&(MsgSpec, String)> {
        let full = match type_name.split('/').collect::<Vec<_>>().as_slice() {
            [pkg, name] => format!("{pkg}/msg/{name}"),
            _ => type_name.to_owned(),
        };
        self.types.get(&full)
    }

    fn require(&self, type_name: &str) -> Result<&MsgSpec, RegistryError> {
        self.get(type_name).ok_or_else(|| RegistryError::UnknownType { name: type_name.to_owned() })
    }

    /// All types `type_name` refers to, directly or not, sorted by `pkg/msg/Name`.
    pub fn dependencies(&self, type_name: &str) -> Result<Vec<&MsgSpec>, RegistryError> {
        let root = self.require(type_name)?;
        let mut seen = BTreeSet::new();
        let mut queue: Vec<(&MsgSpec, TypeRef)> = nested_refs(root).map(|r| (root, r)).collect();
        while let Some((parent, r)) = queue.pop() {
            let name = r.full_name();
            if seen.contains(&name) {
                continue;
            }
            let spec = self
                .get(&name)
                .ok_or_else(|| RegistryError::MissingDependency { name: name.clone(), referenced_by: parent.type_ref().full_name() })?;
            queue.extend(nested_refs(spec).map(|r| (spec, r)));
            seen.insert(name);
        }
        seen.iter().map(|name| self.require(name)).collect()
    }

    /// The canonical JSON that REP-2016 hashes (default values already removed).
    pub fn hashable_description(&self, type_name: &str) -> Result<String, RegistryError> {
        let root = self.require(type_name)?;
        let mut out = String::from("{\"type_description\": ");
        write_individual(&mut out, root);
        out.push_str(", \"referenced_type_descriptions\": [");
        for (i, dep) in self.dependencies(type_name)?.into_iter().enumerate() {
            if i > 0 {
                out.push_str(", ");
            }
            write_individual(&mut out, dep);
        }
        out.push_str("]}");
        Ok(out)
    }

    /// The REP-2016 type hash, `RIHS01_` + lowercase hex SHA-256.
    pub fn type_hash(&self, type_name: &str) -> Result<String, RegistryError> {
        let digest = Sha256::digest(self.hashable_description(type_name)?.as_bytes());
        let mut out = String::with_capacity(7 + 64);
        out.push_str("RIHS01_");
        for byte in digest {
            let _ = write!(out, "{byte:02x}");
        }
        Ok(out)
    }

    /// The MCAP `ros2msg` schema: the type's text, then for each dependency a
    /// line of 80 `=`, `MSG: pkg/Type`, and that type's text.
    pub fn ros2msg_schema(&self, type_name: &str) -> Result<String, RegistryError> {
        let root = self.require(type_name)?;
        let mut out = self.text(&root.type_ref().full_name()).unwrap_or_default().to_owned();
        for dep in self.dependencies(type_name)? {
            let r = dep.type_ref();
            if !out.ends_with('\n') {
                out.push('\n');
            }
            out.push_str(&"=".repeat(80));
            out.push_str("\nMSG: ");
            out.push_str(&r.short_name());
            out.push('\n');
            out.push_str(self.text(&r.full_name()).unwrap_or_default());
        }
        Ok(out)
    }
}

fn nested_refs(spec: &MsgSpec) -> impl Iterator<Item = TypeRef> + '_ {
    spec.fields.iter().filter_map(|f| match &f.ty.base {
        BaseType::Nested(r) => Some(r.clone()),
        _ => None,
    })
}

/// `type_description_interfaces/msg/FieldType` id of the element type.
fn element_type_id(base: &BaseType) -> u8 {
    match base {
        BaseType::Nested(_) => 1,
        BaseType::Primitive(p) => match p {
            PrimitiveType::Int8 => 2,
            // rosidl_adapter maps .msg `char` to IDL uint8 before hashing.
            PrimitiveType::UInt8 | PrimitiveType::Char => 3,
            PrimitiveType::Int16 => 4,
            PrimitiveType::UInt16 => 5,
            PrimitiveType::Int32 => 6,
            PrimitiveType::UInt32 => 7,
            PrimitiveType::Int64 => 8,
            PrimitiveType::UInt64 => 9,
            PrimitiveType::Float32 => 10,
            PrimitiveType::Float64 => 11,
            PrimitiveType::Bool => 15,
            // .msg `byte` is IDL `octet`.
            PrimitiveType::Byte => 16,
        },
        BaseType::String { bound: None } => 17,
        BaseType::WString { bound: None } => 18,
        BaseType::String { bound: Some(_) } => 21,
        BaseType::WString { bound: Some(_) } => 22,
    }
}

/// Returns `(type_id, capacity, string_capacity, nested_type_name)`.
pub(crate) fn field_type_tuple(ty: &FieldType) -> (u32, u32, u32, String) {
    let (offset, capacity) = match ty.collection {
        Collection::Single => (0, 0),
        Collection::Array(n) => (48, n),
        Collection::BoundedSequence(n) => (96, n),
        Collection::UnboundedSequence => (144, 0),
    };
    let string_capacity = match ty.base {
        BaseType::String { bound: Some(n) } | BaseType::WString { bound: Some(n) } => n,
        _ => 0,
    };
    let nested = match &ty.base {
        BaseType::Nested(r) => r.full_name(),
        _ => String::new(),
    };
    (u32::from(element_type_id(&ty.base)) + offset, capacity, string_capacity, nested)
}

fn write_individual(out: &mut String, spec: &MsgSpec) {
    out.push_str("{\"type_name\": ");
    write_json_string(out, &spec.type_ref().full_name());
    out.push_str(", \"fields\": [");
    let dummy = [(EMPTY_STRUCT_MEMBER.to_owned(), (3, 0, 0, String::new()))];
    let fields: Vec<(String, (u32, u32, u32, String))> = if spec.fields.is_empty() {
        dummy.to_vec()
    } else {
        spec.fields.iter().map(|f| (f.name.clone(), field_type_tuple(&f.ty))).collect()
    };
    for (i, (name, (type_id, capacity, string_capacity, nested))) in fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str("{\"name\": ");
        write_json_string(out, name);
        let _ = write!(out, ", \"type\": {{\"type_id\": {type_id}, \"capacity\": {capacity}, \"string_capacity\": {string_capacity}, ");
        out.push_str("\"nested_type_name\": ");
        write_json_string(out, nested);
        out.push_str("}}");
    }
    out.push_str("]}");
}

/// Python `json.dumps(..., ensure_ascii=True)` string escaping.
fn write_json_string(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{08}' => out.push_str("\\b"),
            '\u{0c}' => out.push_str("\\f"),
            c if c.is_ascii() && !c.is_ascii_control() => out.push(c),
            c => {
                let mut units = [0u16; 2];
                for unit in c.encode_utf16(&mut units) {
                    let _ = write!(out, "\\u{unit:04x}");
                }
            }
        }
    }
    out.push('"');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_escaping_matches_python() {
        let mut s = String::new();
        write_json_string(&mut s, "a\"b\\\n\u{1}é😀");
        assert_eq!(s, "\"a\\\"b\\\\\\n\\u0001\\u00e9\\ud83d\\ude00\"");
    }

    #[test]
    fn empty_message_gets_rosidl_placeholder_member() {
        let mut reg = Registry::new();
        reg.add("std_msgs", "Empty", "# nothing\n").expect("valid");
        let json = reg.hashable_description("std_msgs/msg/Empty").expect("registered");
        assert!(json.contains("\"name\": \"structure_needs_at_least_one_member\", \"type\": {\"type_id\": 3,"), "{json}");
    }

    #[test]
    fn missing_dependency_is_reported() {
        let mut reg = Registry::new();
        reg.add("p", "A", "B b\n").expect("valid");
        let e = reg.type_hash("p/msg/A").expect_err("B is not registered");
        assert_eq!(e, RegistryError::MissingDependency { name: "p/msg/B".into(), referenced_by: "p/msg/A".into() });
    }
}
