//! A `.msg` parser that follows `rosidl_adapter` closely enough that the type
//! descriptions (and so the REP-2016 hashes) built from its output match what
//! `rosidl` generates for the same file.

use std::fmt;

/// A primitive `.msg` type. `char` is kept apart from `uint8` so definitions
/// round-trip, even though rosidl maps both to `uint8` for hashing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PrimitiveType {
    Bool,
    Byte,
    Char,
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    Float32,
    Float64,
}

impl PrimitiveType {
    /// Every primitive, in the order `.msg` documentation lists them.
    pub const ALL: [PrimitiveType; 13] = [
        Self::Bool,
        Self::Byte,
        Self::Char,
        Self::Int8,
        Self::UInt8,
        Self::Int16,
        Self::UInt16,
        Self::Int32,
        Self::UInt32,
        Self::Int64,
        Self::UInt64,
        Self::Float32,
        Self::Float64,
    ];

    /// The keyword used in `.msg` files.
    pub fn keyword(self) -> &'static str {
        match self {
            Self::Bool => "bool",
            Self::Byte => "byte",
            Self::Char => "char",
            Self::Int8 => "int8",
            Self::UInt8 => "uint8",
            Self::Int16 => "int16",
            Self::UInt16 => "uint16",
            Self::Int32 => "int32",
            Self::UInt32 => "uint32",
            Self::Int64 => "int64",
            Self::UInt64 => "uint64",
            Self::Float32 => "float32",
            Self::Float64 => "float64",
        }
    }

    fn from_keyword(word: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.keyword() == word)
    }
}

/// A reference to another message type, always resolved to its package.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TypeRef {
    pub package: String,
    pub name: String,
}

impl TypeRef {
    /// The REP-2016 / rosidl full name, `pkg/msg/Name`.
    pub fn full_name(&self) -> String {
        format!("{}/msg/{}", self.package, self.name)
    }

    /// The short name used in `.msg` files and MCAP `MSG:` lines, `pkg/Name`.
    pub fn short_name(&self) -> String {
        format!("{}/{}", self.package, self.name)
    }
}

/// The element type of a field, before any array or sequence wrapping.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum BaseType {
    Primitive(PrimitiveType),
    /// `string` or `string<=N`.
    String {
        bound: Option<u32>,
    },
    /// `wstring` or `wstring<=N`.
    WString {
        bound: Option<u32>,
    },
    Nested(TypeRef),
}

/// How many elements a field holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Collection {
    Single,
    /// `T[N]`: exactly N elements, no length prefix on the wire.
    Array(u32),
    /// `T[<=N]`.
    BoundedSequence(u32),
    /// `T[]`.
    UnboundedSequence,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FieldType {
    pub base: BaseType,
    pub collection: Collection,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub ty: FieldType,
    /// Default value text as written; rosidl leaves it out of the type hash.
    pub default: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Constant {
    pub name: String,
    /// Constants may only be primitives or (possibly bounded) strings.
    pub ty: BaseType,
    pub value: String,
}

/// A parsed `.msg` file. Comments are dropped: they do not reach the hash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MsgSpec {
    pub package: String,
    pub name: String,
    pub fields: Vec<Field>,
    pub constants: Vec<Constant>,
}

impl MsgSpec {
    pub fn type_ref(&self) -> TypeRef {
        TypeRef { package: self.package.clone(), name: self.name.clone() }
    }

    /// Canonical `.msg` text (no comments, package-qualified nested types),
    /// which parses back to an equal spec.
    pub fn to_msg_text(&self) -> String {
        let mut out = String::new();
        for c in &self.constants {
            out.push_str(&format!("{} {}={}\n", base_text(&c.ty), c.name, c.value));
        }
        for f in &self.fields {
            out.push_str(&format!("{} {}", field_type_text(&f.ty), f.name));
            if let Some(d) = &f.default {
                out.push(' ');
                out.push_str(d);
            }
            out.push('\n');
        }
        out
    }
}

fn base_text(base: &BaseType) -> String {
    match base {
        BaseType::Primitive(p) => p.keyword().to_owned(),
        BaseType::String { bound: None } => "string".to_owned(),
        BaseType::String { bound: Some(n) } => format!("string<={n}"),
        BaseType::WString { bound: None } => "wstring".to_owned(),
        BaseType::WString { bound: Some(n) } => format!("wstring<={n}"),
        BaseType::Nested(r) => r.short_name(),
    }
}

/// The type as it would be written in a `.msg` file.
pub fn field_type_text(ty: &FieldType) -> String {
    let base = base_text(&ty.base);
    match ty.collection {
        Collection::Single => base,
        Collection::Array(n) => format!("{base}[{n}]"),
        Collection::BoundedSequence(n) => format!("{base}[<={n}]"),
        Collection::UnboundedSequence => format!("{base}[]"),
    }
}

/// What went wrong on a line; the enclosing [`ParseError`] says where.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParseErrorKind {
    #[error("a field or constant needs a type and a name")]
    MissingName,
    #[error("unknown or malformed type")]
    BadType,
    #[error("array size or bound must be a positive integer")]
    BadSize,
    #[error("invalid field name (lowercase letters, digits and single underscores, starting with a letter)")]
    BadFieldName,
    #[error("invalid constant name (uppercase letters, digits and underscores)")]
    BadConstantName,
    #[error("invalid package name")]
    BadPackageName,
    #[error("invalid message name (CamelCase, starting with an uppercase letter)")]
    BadMessageName,
    #[error("constants must have a primitive or string type")]
    BadConstantType,
    #[error("constant value does not fit its type")]
    BadConstantValue,
    #[error("name is used twice")]
    Duplicate,
}

/// A `.msg` syntax error, naming the file, the 1-based line and the offending token.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}:{line}: {kind}: `{token}`")]
pub struct ParseError {
    pub file: String,
    pub line: usize,
    pub token: String,
    pub kind: ParseErrorKind,
}

fn is_lower_name(s: &str) -> bool {
    // rosidl: ^(?!.*__)(?!.*_$)[a-z][a-z0-9_]*$
    let mut chars = s.chars();
    matches!(chars.next(), Some('a'..='z'))
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !s.contains("__")
        && !s.ends_with('_')
}

fn is_message_name(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some('A'..='Z')) && chars.all(|c| c.is_ascii_alphanumeric())
}

fn is_constant_name(s: &str) -> bool {
    // rosidl: ^[A-Z]([A-Z0-9_]?[A-Z0-9]+)*$
    let mut chars = s.chars();
    matches!(chars.next(), Some('A'..='Z'))
        && chars.all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
        && !s.contains("__")
        && !s.ends_with('_')
}

/// Validates a package and message name pair, as used for `.msg` file identity.
pub fn check_type_name(package: &str, name: &str) -> Result<(), ParseErrorKind> {
    if !is_lower_name(package) {
        return Err(ParseErrorKind::BadPackageName);
    }
    if !is_message_name(name) {
        return Err(ParseErrorKind::BadMessageName);
    }
    Ok(())
}

fn parse_size(text: &str) -> Result<u32, ParseErrorKind> {
    match text.parse::<u32>() {
        Ok(n) if n > 0 && text.bytes().all(|b| b.is_ascii_digit()) => Ok(n),
        _ => Err(ParseErrorKind::BadSize),
    }
}

fn parse_base(text: &str, package: &str) -> Result<BaseType, ParseErrorKind> {
    if let Some(p) = PrimitiveType::from_keyword(text) {
        return Ok(BaseType::Primitive(p));
    }
    for (keyword, wide) in [("string", false), ("wstring", true)] {
        let bound = if text == keyword {
            Some(None)
        } else if let Some(rest) = text.strip_prefix(keyword).and_then(|r| r.strip_prefix("<=")) {
            Some(Some(parse_size(rest)?))
        } else {
            None
        };
        if let Some(bound) = bound {
            return Ok(if wide { BaseType::WString { bound } } else { BaseType::String { bound } });
        }
    }
    let (pkg, name) = match text.split_once('/') {
        Some((pkg, name)) => (pkg, name),
        None => (package, text),
    };
    if !is_lower_name(pkg) {
        return Err(ParseErrorKind::BadPackageName);
    }
    if !is_message_name(name) {
        return Err(ParseErrorKind::BadType);
    }
    Ok(BaseType::Nested(TypeRef { package: pkg.to_owned(), name: name.to_owned() }))
}

/// Parses a type token such as `uint8`, `string<=8`, `pkg/Type[]`, `float32[<=3]`.
pub fn parse_field_type(text: &str, package: &str) -> Result<FieldType, ParseErrorKind> {
    let (base_text, collection) = match text.find('[') {
        None => (text, Collection::Single),
        Some(open) => {
            let inner = text[open + 1..].strip_suffix(']').ok_or(ParseErrorKind::BadType)?;
            let collection = if inner.is_empty() {
                Collection::UnboundedSequence
            } else if let Some(bound) = inner.strip_prefix("<=") {
                Collection::BoundedSequence(parse_size(bound)?)
            } else {
                Collection::Array(parse_size(inner)?)
            };
            (&text[..open], collection)
        }
    };
    Ok(FieldType { base: parse_base(base_text, package)?, collection })
}

fn check_constant_value(ty: &BaseType, value: &str) -> bool {
    let p = match ty {
        BaseType::String { bound } => return bound.is_none_or(|b| value.len() <= b as usize),
        BaseType::WString { bound } => return bound.is_none_or(|b| value.chars().count() <= b as usize),
        BaseType::Nested(_) => return false,
        BaseType::Primitive(p) => *p,
    };
    match p {
        PrimitiveType::Bool => matches!(value, "true" | "false" | "True" | "False" | "0" | "1"),
        PrimitiveType::Byte | PrimitiveType::Char | PrimitiveType::UInt8 => value.parse::<u8>().is_ok(),
        PrimitiveType::Int8 => value.parse::<i8>().is_ok(),
        PrimitiveType::Int16 => value.parse::<i16>().is_ok(),
        PrimitiveType::UInt16 => value.parse::<u16>().is_ok(),
        PrimitiveType::Int32 => value.parse::<i32>().is_ok(),
        PrimitiveType::UInt32 => value.parse::<u32>().is_ok(),
        PrimitiveType::Int64 => value.parse::<i64>().is_ok(),
        PrimitiveType::UInt64 => value.parse::<u64>().is_ok(),
        PrimitiveType::Float32 | PrimitiveType::Float64 => value.parse::<f64>().is_ok(),
    }
}

/// Parses `.msg` text. `file` only labels errors; `package` resolves
/// same-package type references such as `UnitState`.
pub fn parse_msg(file: &str, package: &str, name: &str, text: &str) -> Result<MsgSpec, ParseError> {
    let err = |line: usize, token: &str, kind: ParseErrorKind| ParseError { file: file.to_owned(), line, token: token.to_owned(), kind };
    check_type_name(package, name).map_err(|kind| err(0, &format!("{package}/{name}"), kind))?;
    let mut spec = MsgSpec { package: package.to_owned(), name: name.to_owned(), fields: Vec::new(), constants: Vec::new() };
    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.replace('\t', " ");
        // Like rosidl, '#' always starts a comment, even inside a string constant.
        let code = line.split('#').next().unwrap_or("").trim();
        if code.is_empty() {
            continue;
        }
        let (type_token, rest) = code.split_once(' ').map(|(t, r)| (t, r.trim_start())).unwrap_or((code, ""));
        if rest.is_empty() {
            return Err(err(line_no, type_token, ParseErrorKind::MissingName));
        }
        let ty = parse_field_type(type_token, package).map_err(|kind| err(line_no, type_token, kind))?;
        if let Some((const_name, value)) = rest.split_once('=') {
            let (const_name, value) = (const_name.trim_end(), value.trim());
            if !is_constant_name(const_name) {
                return Err(err(line_no, const_name, ParseErrorKind::BadConstantName));
            }
            if ty.collection != Collection::Single || matches!(ty.base, BaseType::Nested(_)) {
                return Err(err(line_no, type_token, ParseErrorKind::BadConstantType));
            }
            if !check_constant_value(&ty.base, value) {
                return Err(err(line_no, value, ParseErrorKind::BadConstantValue));
            }
            if spec.constants.iter().any(|c| c.name == const_name) {
                return Err(err(line_no, const_name, ParseErrorKind::Duplicate));
            }
            spec.constants.push(Constant { name: const_name.to_owned(), ty: ty.base, value: value.to_owned() });
        } else {
            let (field_name, default) = match rest.split_once(' ') {
                Some((n, d)) => (n, Some(d.trim().to_owned())),
                None => (rest, None),
            };
            if !is_lower_name(field_name) {
                return Err(err(line_no, field_name, ParseErrorKind::BadFieldName));
            }
            if spec.fields.iter().any(|f| f.name == field_name) {
                return Err(err(line_no, field_name, ParseErrorKind::Duplicate));
            }
            spec.fields.push(Field { name: field_name.to_owned(), ty, default });
        }
    }
    Ok(spec)
}

impl fmt::Display for TypeRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.full_name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_form() {
        let text = "# comment\n\nuint8 A=1 # trailing\nstring<=4 S=abc\nint32[3] a\nstring<=8[<=2] b\nOther c\nstd_msgs/Header[] d\nfloat64 e 1.5\n";
        let spec = parse_msg("T.msg", "pkg", "T", text).expect("valid");
        assert_eq!(spec.constants.len(), 2);
        assert_eq!(spec.constants[0].value, "1");
        assert_eq!(spec.constants[1].ty, BaseType::String { bound: Some(4) });
        let kinds: Vec<_> = spec.fields.iter().map(|f| field_type_text(&f.ty)).collect();
        assert_eq!(kinds, ["int32[3]", "string<=8[<=2]", "pkg/Other", "std_msgs/Header[]", "float64"]);
        assert_eq!(spec.fields[4].default.as_deref(), Some("1.5"));
    }

    #[test]
    fn errors_name_file_line_and_token() {
        let e = parse_msg("X.msg", "pkg", "X", "uint8 ok\n\nuint9 bad\n").expect_err("uint9 is not a type");
        assert_eq!((e.file.as_str(), e.line, e.token.as_str(), &e.kind), ("X.msg", 3, "uint9", &ParseErrorKind::BadType));
        let e = parse_msg("X.msg", "pkg", "X", "uint8 Bad\n").expect_err("field names are lowercase");
        assert_eq!((e.line, e.token.as_str()), (1, "Bad"));
        let e = parse_msg("X.msg", "pkg", "X", "uint8[0] a\n").expect_err("zero-size arrays are invalid");
        assert_eq!(e.kind, ParseErrorKind::BadSize);
        let e = parse_msg("X.msg", "pkg", "X", "uint8 A=300\n").expect_err("300 does not fit uint8");
        assert_eq!((e.token.as_str(), &e.kind), ("300", &ParseErrorKind::BadConstantValue));
        assert!(e.to_string().starts_with("X.msg:1:"));
    }
}
