//! Each Rust struct must have the `.msg` fields, in order, with matching wire
//! types: CDR carries no names, so a swapped or retyped field would silently
//! corrupt every message. The Rust side is observed through serde itself
//! (a recording `Serializer`), not through a hand-written list.

use crate::common::*;
use avacraft_msgs::{
    AbilityState, BaseType, Collection, EpisodeStatus, FieldType, PrimitiveType, Registry, RoleGroup, RosMessage, SessionInfo, UnitAction,
    UnitState, embedded_registry,
};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::TestRunner;
use serde::ser::{self, Serialize};

#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Bool,
    I32,
    U8,
    U32,
    U64,
    F32,
    F64,
    Str,
    Bytes,
    Seq(Option<Box<Shape>>),
    Tuple(Vec<Shape>),
    Struct(&'static str, Vec<(&'static str, Shape)>),
}

#[derive(Debug)]
struct Unsupported(String);
impl std::fmt::Display for Unsupported {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for Unsupported {}
impl ser::Error for Unsupported {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        Self(msg.to_string())
    }
}

struct Recorder;
struct Compound {
    name: &'static str,
    items: Vec<Shape>,
    fields: Vec<(&'static str, Shape)>,
}

fn no<T>(what: &str) -> Result<T, Unsupported> {
    Err(Unsupported(format!("{what} has no .msg equivalent")))
}

impl ser::Serializer for Recorder {
    type Ok = Shape;
    type Error = Unsupported;
    type SerializeSeq = Compound;
    type SerializeTuple = Compound;
    type SerializeTupleStruct = ser::Impossible<Shape, Unsupported>;
    type SerializeTupleVariant = ser::Impossible<Shape, Unsupported>;
    type SerializeMap = ser::Impossible<Shape, Unsupported>;
    type SerializeStruct = Compound;
    type SerializeStructVariant = ser::Impossible<Shape, Unsupported>;

    fn serialize_bool(self, _: bool) -> Result<Shape, Unsupported> {
        Ok(Shape::Bool)
    }
    fn serialize_i8(self, _: i8) -> Result<Shape, Unsupported> {
        no("i8")
    }
    fn serialize_i16(self, _: i16) -> Result<Shape, Unsupported> {
        no("i16")
    }
    fn serialize_i32(self, _: i32) -> Result<Shape, Unsupported> {
        Ok(Shape::I32)
    }
    fn serialize_i64(self, _: i64) -> Result<Shape, Unsupported> {
        no("i64")
    }
    fn serialize_u8(self, _: u8) -> Result<Shape, Unsupported> {
        Ok(Shape::U8)
    }
    fn serialize_u16(self, _: u16) -> Result<Shape, Unsupported> {
        no("u16")
    }
    fn serialize_u32(self, _: u32) -> Result<Shape, Unsupported> {
        Ok(Shape::U32)
    }
    fn serialize_u64(self, _: u64) -> Result<Shape, Unsupported> {
        Ok(Shape::U64)
    }
    fn serialize_f32(self, _: f32) -> Result<Shape, Unsupported> {
        Ok(Shape::F32)
    }
    fn serialize_f64(self, _: f64) -> Result<Shape, Unsupported> {
        Ok(Shape::F64)
    }
    fn serialize_char(self, _: char) -> Result<Shape, Unsupported> {
        no("char")
    }
    fn serialize_str(self, _: &str) -> Result<Shape, Unsupported> {
        Ok(Shape::Str)
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<Shape, Unsupported> {
        Ok(Shape::Bytes)
    }
    fn serialize_none(self) -> Result<Shape, Unsupported> {
        no("Option")
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<Shape, Unsupported> {
        no("Option")
    }
    fn serialize_unit(self) -> Result<Shape, Unsupported> {
        no("()")
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<Shape, Unsupported> {
        no("unit struct")
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<Shape, Unsupported> {
        no("enum")
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(self, _: &'static str, _: &T) -> Result<Shape, Unsupported> {
        no("newtype")
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<Shape, Unsupported> {
        no("enum")
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Compound, Unsupported> {
        Ok(Compound { name: "", items: Vec::new(), fields: Vec::new() })
    }
    fn serialize_tuple(self, _: usize) -> Result<Compound, Unsupported> {
        Ok(Compound { name: "", items: Vec::new(), fields: Vec::new() })
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Self::SerializeTupleStruct, Unsupported> {
        no("tuple struct")
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, Unsupported> {
        no("enum")
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Unsupported> {
        no("map")
    }
    fn serialize_struct(self, name: &'static str, _: usize) -> Result<Compound, Unsupported> {
        Ok(Compound { name, items: Vec::new(), fields: Vec::new() })
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, Unsupported> {
        no("enum")
    }
}

impl ser::SerializeSeq for Compound {
    type Ok = Shape;
    type Error = Unsupported;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, value: &T) -> Result<(), Unsupported> {
        self.items.push(value.serialize(Recorder)?);
        Ok(())
    }
    fn end(self) -> Result<Shape, Unsupported> {
        // All elements of a sequence must have one shape; report the first.
        let first = self.items.first().cloned();
        if self.items.iter().any(|s| Some(s) != first.as_ref()) {
            return Err(Unsupported("heterogeneous sequence".into()));
        }
        Ok(Shape::Seq(first.map(Box::new)))
    }
}

impl ser::SerializeTuple for Compound {
    type Ok = Shape;
    type Error = Unsupported;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, value: &T) -> Result<(), Unsupported> {
        self.items.push(value.serialize(Recorder)?);
        Ok(())
    }
    fn end(self) -> Result<Shape, Unsupported> {
        Ok(Shape::Tuple(self.items))
    }
}

impl ser::SerializeStruct for Compound {
    type Ok = Shape;
    type Error = Unsupported;
    fn serialize_field<T: ?Sized + Serialize>(&mut self, key: &'static str, value: &T) -> Result<(), Unsupported> {
        self.fields.push((key, value.serialize(Recorder)?));
        Ok(())
    }
    fn end(self) -> Result<Shape, Unsupported> {
        Ok(Shape::Struct(self.name, self.fields))
    }
}

fn primitive_shape(p: PrimitiveType) -> Option<Shape> {
    Some(match p {
        PrimitiveType::Bool => Shape::Bool,
        PrimitiveType::UInt8 | PrimitiveType::Byte | PrimitiveType::Char => Shape::U8,
        PrimitiveType::Int32 => Shape::I32,
        PrimitiveType::UInt32 => Shape::U32,
        PrimitiveType::UInt64 => Shape::U64,
        PrimitiveType::Float32 => Shape::F32,
        PrimitiveType::Float64 => Shape::F64,
        _ => return None, // not used by any embedded type; extend when one is
    })
}

/// Checks a recorded value against a `.msg` field type; `path` names the spot for failures.
fn check_field(reg: &Registry, path: &str, shape: &Shape, ty: &FieldType) -> Result<(), String> {
    let element = |shape: &Shape| check_field(reg, path, shape, &FieldType { base: ty.base.clone(), collection: Collection::Single });
    match (ty.collection, shape) {
        (Collection::Single, _) => match (&ty.base, shape) {
            (BaseType::Primitive(p), s) if primitive_shape(*p).as_ref() == Some(s) => Ok(()),
            (BaseType::String { bound: None }, Shape::Str) => Ok(()),
            (BaseType::Nested(r), Shape::Struct(_, fields)) => check_struct(reg, &r.full_name(), fields),
            _ => Err(format!("{path}: Rust {shape:?} does not match .msg {ty:?}")),
        },
        (Collection::UnboundedSequence, Shape::Bytes) if ty.base == BaseType::Primitive(PrimitiveType::UInt8) => Ok(()),
        (Collection::UnboundedSequence, Shape::Seq(Some(e))) if ty.base != BaseType::Primitive(PrimitiveType::UInt8) => element(e),
        (Collection::Array(n), Shape::Tuple(items)) if items.len() == n as usize => items.iter().try_for_each(element),
        _ => Err(format!(
            "{path}: Rust {shape:?} does not match .msg {ty:?} (uint8[] must use serde_bytes; sample sequences must be non-empty)"
        )),
    }
}

fn check_struct(reg: &Registry, type_name: &str, fields: &[(&'static str, Shape)]) -> Result<(), String> {
    let spec = reg.get(type_name).ok_or_else(|| format!("{type_name} not registered"))?;
    let rust: Vec<&str> = fields.iter().map(|(n, _)| *n).collect();
    let msg: Vec<&str> = spec.fields.iter().map(|f| f.name.as_str()).collect();
    if rust != msg {
        return Err(format!("{type_name}: Rust fields {rust:?} != .msg fields {msg:?}"));
    }
    for ((name, shape), field) in fields.iter().zip(&spec.fields) {
        check_field(reg, &format!("{type_name}.{name}"), shape, &field.ty)?;
    }
    Ok(())
}

fn check<T: RosMessage>(strategy: impl Strategy<Value = T>) {
    let mut runner = TestRunner::deterministic();
    for _ in 0..8 {
        let value = strategy.new_tree(&mut runner).expect("strategy").current();
        let shape = value.serialize(Recorder).expect("serde shape of a message");
        let Shape::Struct(_, fields) = shape else { panic!("{} does not serialize as a struct", T::TYPE_NAME) };
        if let Err(e) = check_struct(embedded_registry(), T::TYPE_NAME, &fields) {
            panic!("{e}");
        }
    }
}

#[test]
fn every_struct_matches_its_msg() {
    check(time());
    check(header());
    check(std_string());
    check(image(1));
    check(unit_state(1));
    check(ability_state());
    check(area_effect());
    check(unit_observation(1));
    check(team_observation(1));
    check(unit_action());
    check(action_batch(1));
    check(episode_status());
    check(role_group(1));
    check(role_assignment(1));
    check(session_info(1));
    check(model_call(1));
    check(team_features(1));
}

/// The checker itself must catch a swapped field, or the test above proves nothing.
#[test]
fn checker_detects_mismatches() {
    let mut reg = Registry::new();
    reg.add("p", "T", "uint32 a\nfloat32 b\nuint8[] c\n").expect("valid");
    let good = vec![("a", Shape::U32), ("b", Shape::F32), ("c", Shape::Bytes)];
    assert!(check_struct(&reg, "p/msg/T", &good).is_ok());
    let swapped = vec![("b", Shape::F32), ("a", Shape::U32), ("c", Shape::Bytes)];
    assert!(check_struct(&reg, "p/msg/T", &swapped).is_err());
    let retyped = vec![("a", Shape::U32), ("b", Shape::U32), ("c", Shape::Bytes)];
    assert!(check_struct(&reg, "p/msg/T", &retyped).is_err());
    let slow_bytes = vec![("a", Shape::U32), ("b", Shape::F32), ("c", Shape::Seq(Some(Box::new(Shape::U8))))];
    assert!(check_struct(&reg, "p/msg/T", &slow_bytes).is_err());
}

/// The `.msg` constants whose names are in `rust` (a message may define more, e.g. the
/// engine's unit types, checked where the engine is known).
fn msg_constants<T: RosMessage>(rust: &[(&str, u8)]) -> Vec<(String, u8)> {
    let spec = embedded_registry().get(T::TYPE_NAME).expect("embedded");
    spec.constants
        .iter()
        .filter(|c| rust.iter().any(|(n, _)| *n == c.name))
        .map(|c| (c.name.clone(), c.value.parse::<u8>().expect("uint8 constant")))
        .collect()
}

fn check_constants<T: RosMessage>(rust: &[(&str, u8)]) {
    let r: Vec<(String, u8)> = rust.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect();
    assert_eq!(r, msg_constants::<T>(rust), "{}", T::TYPE_NAME);
}

#[test]
fn rust_constants_match_msg_constants() {
    check_constants::<UnitAction>(UnitAction::CONSTANTS);
    check_constants::<EpisodeStatus>(EpisodeStatus::CONSTANTS);
    check_constants::<UnitState>(UnitState::CONSTANTS);
    check_constants::<AbilityState>(AbilityState::CONSTANTS);
    check_constants::<RoleGroup>(RoleGroup::CONSTANTS);
    check_constants::<avacraft_msgs::ModelCall>(avacraft_msgs::ModelCall::CONSTANTS);
    // Every constant of the messages whose constants are all mirrored here.
    for (spec, n) in [
        (UnitAction::TYPE_NAME, UnitAction::CONSTANTS.len()),
        (RoleGroup::TYPE_NAME, RoleGroup::CONSTANTS.len()),
        (avacraft_msgs::ModelCall::TYPE_NAME, avacraft_msgs::ModelCall::CONSTANTS.len()),
    ] {
        assert_eq!(embedded_registry().get(spec).expect("embedded").constants.len(), n, "{spec}");
    }
}

/// Every constant of `SessionInfo.msg`, in order, mirrored in Rust.
#[test]
fn session_info_constants_match_msg() {
    let spec = embedded_registry().get(SessionInfo::TYPE_NAME).expect("embedded");
    let msg: Vec<(String, u8)> = spec.constants.iter().map(|c| (c.name.clone(), c.value.parse::<u8>().expect("uint8 constant"))).collect();
    let rust: Vec<(String, u8)> = SessionInfo::CONSTANTS.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect();
    assert_eq!(rust, msg);
}

/// The geometry and `foxglove_msgs` types the live view records, each sample with one element
/// in every sequence so the element types are checked too.
#[test]
fn the_recorded_live_view_types_match_their_msgs() {
    use avacraft_msgs::builtin_interfaces::{Duration, Time};
    use avacraft_msgs::foxglove_msgs::*;
    use avacraft_msgs::geometry_msgs::{Point, Pose, Vector3};
    let t = Time { sec: 1, nanosec: 2 };
    let c = Color { r: 0.1, g: 0.2, b: 0.3, a: 1.0 };
    let pose = Pose::default();
    let v = Vector3 { x: 1.0, y: 2.0, z: 3.0 };
    let p2 = Point2 { x: 1.0, y: 2.0 };
    let p = Point { x: 1.0, y: 2.0, z: 3.0 };
    let entity = SceneEntity {
        timestamp: t,
        frame_id: "map".into(),
        id: "u1".into(),
        lifetime: Duration { sec: 0, nanosec: 5 },
        frame_locked: true,
        metadata: vec![KeyValuePair { key: "k".into(), value: "v".into() }],
        arrows: vec![ArrowPrimitive { pose, shaft_length: 1.0, shaft_diameter: 0.1, head_length: 0.2, head_diameter: 0.3, color: c }],
        cubes: vec![CubePrimitive { pose, size: v, color: c }],
        spheres: vec![SpherePrimitive { pose, size: v, color: c }],
        cylinders: vec![CylinderPrimitive { pose, size: v, bottom_scale: 1.0, top_scale: 0.5, color: c }],
        lines: vec![LinePrimitive {
            r#type: 1,
            pose,
            thickness: 0.1,
            scale_invariant: true,
            points: vec![p],
            color: c,
            colors: vec![c],
            indices: vec![0],
        }],
        triangles: vec![TriangleListPrimitive { pose, points: vec![p], color: c, colors: vec![c], indices: vec![0] }],
        texts: vec![TextPrimitive { pose, billboard: true, font_size: 12.0, scale_invariant: false, color: c, text: "x".into() }],
        models: vec![ModelPrimitive {
            pose,
            scale: v,
            color: c,
            override_color: false,
            url: "u".into(),
            media_type: "m".into(),
            data: vec![1],
        }],
    };
    let deletion = SceneEntityDeletion { timestamp: t, r#type: SceneEntityDeletion::ALL, id: String::new() };
    check(Just(SceneUpdate { deletions: vec![deletion], entities: vec![entity] }));
    check(Just(ImageAnnotations {
        circles: vec![CircleAnnotation { timestamp: t, position: p2, diameter: 3.0, thickness: 1.0, fill_color: c, outline_color: c }],
        points: vec![PointsAnnotation {
            timestamp: t,
            r#type: 1,
            points: vec![p2],
            outline_color: c,
            outline_colors: vec![c],
            fill_color: c,
            thickness: 1.0,
        }],
        texts: vec![TextAnnotation { timestamp: t, position: p2, text: "t".into(), font_size: 9.0, text_color: c, background_color: c }],
    }));
    check(Just(Log { timestamp: t, level: Log::INFO, message: "m".into(), name: "n".into(), file: "f".into(), line: 3 }));
    // The constants the Rust side names are the .msg's.
    let constants = |type_name: &str| -> Vec<(String, String)> {
        let spec = embedded_registry().get(type_name).expect("embedded");
        spec.constants.iter().map(|c| (c.name.clone(), c.value.clone())).collect()
    };
    assert!(constants(SceneEntityDeletion::TYPE_NAME).contains(&("ALL".into(), SceneEntityDeletion::ALL.to_string())));
    assert!(constants(Log::TYPE_NAME).contains(&("INFO".into(), Log::INFO.to_string())));
    assert!(constants(Log::TYPE_NAME).contains(&("ERROR".into(), Log::ERROR.to_string())));
}
