//! Prints name, DDS name and REP-2016 hash of every embedded type
//! (`cargo run --example type_table`), e.g. for rmw_zenoh key expressions.

use avacraft_msgs::{EMBEDDED_TYPES, embedded_registry};

fn main() {
    for t in EMBEDDED_TYPES {
        let name = format!("{}/msg/{}", t.package, t.name);
        match embedded_registry().type_hash(&name) {
            Ok(hash) => println!("{name}\t{}::msg::dds_::{}_\t{hash}", t.package, t.name),
            Err(e) => eprintln!("{name}: {e}"),
        }
    }
}
