//! `.msg` parser: never panics, and generated definitions round-trip.

use avacraft_msgs::{BaseType, Collection, Constant, EMBEDDED_TYPES, Field, FieldType, MsgSpec, PrimitiveType, TypeRef, parse_msg};
use proptest::prelude::*;

fn package() -> impl Strategy<Value = String> {
    prop_oneof![Just("avacraft_msgs".to_owned()), Just("std_msgs".to_owned()), "[a-z][a-z0-9]{0,6}(_[a-z0-9]{1,3})?"]
}

fn message_name() -> impl Strategy<Value = String> {
    "[A-Z][A-Za-z0-9]{0,8}"
}

fn bound() -> impl Strategy<Value = Option<u32>> {
    prop_oneof![Just(None), (4u32..300).prop_map(Some)]
}

fn base_type() -> impl Strategy<Value = BaseType> {
    prop_oneof![
        proptest::sample::select(PrimitiveType::ALL.to_vec()).prop_map(BaseType::Primitive),
        bound().prop_map(|bound| BaseType::String { bound }),
        bound().prop_map(|bound| BaseType::WString { bound }),
        (package(), message_name()).prop_map(|(package, name)| BaseType::Nested(TypeRef { package, name })),
    ]
}

fn collection() -> impl Strategy<Value = Collection> {
    prop_oneof![
        Just(Collection::Single),
        (1u32..100).prop_map(Collection::Array),
        (1u32..100).prop_map(Collection::BoundedSequence),
        Just(Collection::UnboundedSequence),
    ]
}

fn field(index: usize) -> impl Strategy<Value = Field> {
    ("[a-z][a-z0-9]{0,6}", base_type(), collection(), proptest::option::of("[a-z0-9.]{1,4}")).prop_map(move |(base, b, c, default)| Field {
        name: format!("{base}_{index}"),
        ty: FieldType { base: b, collection: c },
        default,
    })
}

fn constant(index: usize) -> impl Strategy<Value = Constant> {
    let typed = prop_oneof![
        proptest::sample::select(PrimitiveType::ALL.to_vec()).prop_flat_map(|p| {
            let value = if p == PrimitiveType::Bool {
                prop_oneof![Just("true".to_owned()), Just("false".to_owned())].boxed()
            } else {
                (0u8..=127).prop_map(|v| v.to_string()).boxed()
            };
            (Just(BaseType::Primitive(p)), value)
        }),
        (bound(), "[a-z0-9]{0,4}").prop_map(|(bound, v)| (BaseType::String { bound }, v)),
    ];
    ("[A-Z][A-Z0-9]{0,5}", typed).prop_map(move |(name, (ty, value))| Constant { name: format!("{name}_{index}"), ty, value })
}

fn spec() -> impl Strategy<Value = MsgSpec> {
    (package(), message_name(), 0usize..8, 0usize..4).prop_flat_map(|(package, name, n_fields, n_constants)| {
        let fields: Vec<_> = (0..n_fields).map(field).collect();
        let constants: Vec<_> = (0..n_constants).map(constant).collect();
        (Just(package), Just(name), fields, constants).prop_map(|(package, name, fields, constants)| MsgSpec {
            package,
            name,
            fields,
            constants,
        })
    })
}

/// Lines that look like `.msg` syntax, so the fuzzer reaches past the first token.
fn msg_like_line() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just("uint8".to_owned()),
        Just("string<=".to_owned()),
        Just("[".to_owned()),
        Just("]".to_owned()),
        Just("[<=".to_owned()),
        Just("=".to_owned()),
        Just("#".to_owned()),
        Just(" ".to_owned()),
        Just("/".to_owned()),
        Just("pkg/Type".to_owned()),
        "[a-zA-Z0-9_]{1,5}",
        "\\PC{1,3}",
    ];
    proptest::collection::vec(token, 0..8).prop_map(|t| t.concat())
}

proptest! {
    #[test]
    fn generated_definitions_round_trip(spec in spec()) {
        let text = spec.to_msg_text();
        let parsed = parse_msg("gen.msg", &spec.package, &spec.name, &text);
        prop_assert_eq!(parsed.as_ref(), Ok(&spec), "text:\n{}", text);
    }

    #[test]
    fn comments_and_blank_lines_are_ignored(spec in spec(), comment in "[^\n\r]{0,20}") {
        let mut text = format!("# {comment}\n\n");
        for line in spec.to_msg_text().lines() {
            text.push_str(&format!("{line}   # {comment}\n\t\n  # indented {comment}\n"));
        }
        prop_assert_eq!(parse_msg("gen.msg", &spec.package, &spec.name, &text), Ok(spec));
    }

    #[test]
    fn parser_never_panics_on_arbitrary_text(text in "\\PC{0,200}") {
        if let Err(e) = parse_msg("fuzz.msg", "pkg", "Fuzz", &text) {
            prop_assert_eq!(e.file.as_str(), "fuzz.msg");
            prop_assert!(e.line >= 1 && e.line <= text.lines().count(), "line {} of {}", e.line, text.lines().count());
        }
    }

    #[test]
    fn parser_never_panics_on_msg_like_text(lines in proptest::collection::vec(msg_like_line(), 0..10)) {
        let text = lines.join("\n");
        if let Err(e) = parse_msg("fuzz.msg", "pkg", "Fuzz", &text) {
            let line = text.lines().nth(e.line - 1).unwrap_or_default();
            prop_assert!(line.contains(e.token.as_str()), "token {:?} not on line {:?}", e.token, line);
        }
    }
}

#[test]
fn every_embedded_definition_parses() {
    for t in EMBEDDED_TYPES {
        let spec = parse_msg(&format!("{}.msg", t.name), t.package, t.name, t.definition).expect("embedded definition");
        assert!(!spec.fields.is_empty(), "{} has no fields", t.name);
    }
}

#[test]
fn bad_type_names_are_rejected() {
    assert!(parse_msg("x.msg", "Bad_Pkg", "X", "").is_err());
    assert!(parse_msg("x.msg", "pkg", "lower", "").is_err());
    assert!(parse_msg("x.msg", "pkg", "X", "uint8 a__b\n").is_err());
    assert!(parse_msg("x.msg", "pkg", "X", "uint8 a_\n").is_err());
    assert!(parse_msg("x.msg", "pkg", "X", "uint8 a\nuint8 a\n").is_err());
    assert!(parse_msg("x.msg", "pkg", "X", "Pkg/Type a\n").is_err());
    assert!(parse_msg("x.msg", "pkg", "X", "uint8[ a\n").is_err());
}
