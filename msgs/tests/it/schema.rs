//! MCAP `ros2msg` schemas: the type's text, then each dependency after an 80-`=` line.

use avacraft_msgs::{EMBEDDED_TYPES, Image, RosMessage, Time, UnitObservation, embedded_registry, parse_msg};

fn separator() -> String {
    "=".repeat(80)
}

#[test]
fn image_schema_is_image_then_sorted_dependencies() {
    let reg = embedded_registry();
    let expected = format!(
        "{}{}\nMSG: builtin_interfaces/Time\n{}{}\nMSG: std_msgs/Header\n{}",
        Image::DEFINITION,
        separator(),
        reg.text("builtin_interfaces/msg/Time").expect("embedded"),
        separator(),
        reg.text("std_msgs/msg/Header").expect("embedded"),
    );
    assert_eq!(Image::schema(), expected);
}

#[test]
fn leaf_type_schema_is_its_definition() {
    assert_eq!(Time::schema(), Time::DEFINITION);
}

#[test]
fn unit_observation_lists_its_transitive_dependencies_in_order() {
    let names: Vec<&str> = UnitObservation::schema().lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
    assert_eq!(
        names,
        ["avacraft_msgs/AbilityState", "avacraft_msgs/AreaEffect", "avacraft_msgs/UnitState", "builtin_interfaces/Time", "std_msgs/Header"]
    );
}

/// A reader splitting on the separator gets back every definition intact.
#[test]
fn every_schema_splits_back_into_parsable_definitions() {
    let reg = embedded_registry();
    for t in EMBEDDED_TYPES {
        let full = format!("{}/msg/{}", t.package, t.name);
        let schema = reg.ros2msg_schema(&full).expect("embedded");
        let deps = reg.dependencies(&full).expect("embedded");
        let sep = format!("\n{}\n", separator());
        let sections: Vec<&str> = schema.split(&sep).collect();
        assert_eq!(sections.len(), deps.len() + 1, "{full}");
        assert_eq!(sections[0].trim_end_matches('\n'), t.definition.trim_end_matches('\n'));
        for (section, dep) in sections[1..].iter().zip(&deps) {
            let (first, body) = section.split_once('\n').expect("MSG line");
            assert_eq!(first, format!("MSG: {}/{}", dep.package, dep.name));
            assert_eq!(parse_msg("schema", &dep.package, &dep.name, body).as_ref(), Ok(*dep));
        }
        for line in schema.lines().filter(|l| l.starts_with('=')) {
            assert_eq!(line.len(), 80);
            assert!(line.bytes().all(|b| b == b'='));
        }
    }
}
