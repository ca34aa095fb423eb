#!/usr/bin/env python3
"""Builds the engine's per-data-set unit tables (engine/src/units/sets/, one file per set) from
StarCraft II's own catalog data, as resolved per mod in the reference folder (sc2_data/).

Usage: python3 tools/gen_units.py [REFERENCE_DIR] [OUT_DIR]
Defaults: ../shared/reference and engine/src/units/sets.

Three sets are written:
- liberty: Core + Liberty at SC2 4.10 (SMAC, SMACv2 and 17 of the paper's maps);
- void: Core + Liberty + Swarm + Void at 4.10 (5 of the paper's maps);
- ladder: the multiplayer mod VoidMulti at 4.10, with the values python-sc2's dump of patch
  5.0.9 records (life, shields, armour, sight, speed, weapon damage, range, period, bonuses)
  laid over it, so that it stays the ladder data the engine played before.
Weapon timing (damage point, backswing, range slop, scan range, random delay, missile speed)
is the resolved weapon's in every set; python-sc2's dump has none.

The generator stops with an error on any weapon shape it does not know, so a change in the
reference data cannot slip into the tables unread.
"""
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REF = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "reference"
OUT = Path(sys.argv[2]) if len(sys.argv) > 2 else ROOT / "engine" / "src" / "units" / "sets"

# The engine's unit kinds, in `UnitKind` order, and their names in the game's data.
KINDS = [
    ("Marine", "Marine"), ("Marauder", "Marauder"), ("Medivac", "Medivac"), ("SiegeTank", "SiegeTank"),
    ("SiegeTankSieged", "SiegeTankSieged"), ("Reaper", "Reaper"), ("Hellbat", "HellionTank"),
    ("VikingAssault", "VikingAssault"), ("VikingFighter", "VikingFighter"), ("Ghost", "Ghost"),
    ("Banshee", "Banshee"), ("Zealot", "Zealot"), ("Stalker", "Stalker"), ("Sentry", "Sentry"),
    ("HighTemplar", "HighTemplar"), ("Archon", "Archon"), ("Immortal", "Immortal"), ("Colossus", "Colossus"),
    ("Phoenix", "Phoenix"), ("WarpPrism", "WarpPrism"), ("WarpPrismPhasing", "WarpPrismPhasing"),
    ("PhotonCannon", "PhotonCannon"), ("Zergling", "Zergling"), ("Baneling", "Baneling"), ("Ultralisk", "Ultralisk"),
    ("Queen", "Queen"), ("SpineCrawler", "SpineCrawler"), ("Hydralisk", "Hydralisk"),
]
ATTRS = {"Light": "L", "Armored": "A", "Biological": "B", "Mechanical": "M", "Psionic": "P", "Massive": "MS", "Structure": "S"}
# A Colossus lance sweeps a segment across the target; the data places its 11 search points
# in the effect tree's offsets, which were not resolved to a length: the engine's 2.5 is kept.
LANCE_HALF_LENGTH = 1.25


def num(v, default=0.0):
    return float(default if v is None else v)


def lit(v):
    s = repr(float(v))
    return s


def attrs(names):
    parts = [ATTRS[a] for a in names if a in ATTRS]
    if not parts:
        return "super::Attrs::NONE"
    out = parts[0]
    for p in parts[1:]:
        out = f"{out}.union({p})"
    return out


def bonus(b):
    items = [f"({ATTRS[k]}, {lit(v)})" for k, v in sorted(b.items(), key=lambda kv: list(ATTRS).index(kv[0]))]
    return "&[" + ", ".join(items) + "]"


def reach(filters):
    required = filters.split(";")[0].split(",")
    if "Structure" in required:
        return None  # a weapon that only hits structures (D8 Charge, Ram): not modelled
    if "Air" in required:
        return "Air"
    if "Ground" in required:
        return "Ground"
    return "Any"


def shape(unit, w):
    """The engine's splash shape, damage, bonus and suicide flag for one weapon's effect tree."""
    dmg = w["summary"]["damage"]
    name = w["name"]
    if name == "VolatileBurst":  # Baneling: every enemy within 2.2 takes it; structures 80 ignoring armour
        unit_hit = next(d for d in dmg if d["splash_area"] and d["amount"] != 80)
        struct = next(d for d in dmg if d["splash_area"] and d["amount"] == 80)
        zones = [(z["Radius"], z["Fraction"]) for z in unit_hit["splash_area"]]
        b = dict(unit_hit["attribute_bonus"])
        b["Structure"] = struct["amount"] - unit_hit["amount"]
        return unit_hit["amount"], b, f"Splash::Radial {{ zones: &{zones_lit(zones)}, friendly_fire: false }}", True
    if name == "ThermalLances":  # Colossus: two lances, each sweeping across the target
        primary = dmg[0]
        return primary["amount"], primary["attribute_bonus"], f"Splash::Line {{ half_length: {lit(LANCE_HALF_LENGTH)}, fraction: 1.0 }}", False
    primary = dmg[0]
    rest = dmg[1:]
    if name == "CrucioShockCannon":  # sieged tank: splash on small targets, one hit on large ones
        zones = [(z["Radius"], z["Fraction"]) for z in primary["splash_area"]]
        ff = "Player" not in primary["search_filters"].split(";")[1]
        return primary["amount"], primary["attribute_bonus"], f"Splash::Radial {{ zones: &{zones_lit(zones)}, friendly_fire: {str(ff).lower()} }}", False
    if primary["splash_area"] and any("Arc" in z for z in primary["splash_area"]):
        # Void's Ultralisk: 33% to enemies within 2 in a 45- and a 180-degree arc; the wider
        # arc contains the narrower, so one 180-degree cone carries it.
        z = max(primary["splash_area"], key=lambda z: z["Arc"])
        return primary["amount"], primary["attribute_bonus"], cone(z["Radius"], z["Arc"], z["Fraction"], unit), False
    if primary["splash_area"]:
        zones = [(z["Radius"], z["Fraction"]) for z in primary["splash_area"]]
        ff = "Player" not in primary["search_filters"].split(";")[1]
        return primary["amount"], primary["attribute_bonus"], f"Splash::Radial {{ zones: &{zones_lit(zones)}, friendly_fire: {str(ff).lower()} }}", False
    areas = [d for d in rest if d["reached_via_area_search"]]
    if areas:
        a = areas[0]["reached_via_area_search"]
        if a["arc"] is None:
            raise SystemExit(f"{unit}: {name}: an area search without an arc is not a known shape")
        frac = areas[0]["amount"] / primary["amount"]
        return primary["amount"], primary["attribute_bonus"], cone(a["radius"], a["arc"], frac, unit), False
    for d in rest:
        same = d["amount"] == primary["amount"] and d["attribute_bonus"] == primary["attribute_bonus"]
        if not same:
            raise SystemExit(f"{unit}: {name}: a second damage effect of another amount is not a known shape")
    return primary["amount"], primary["attribute_bonus"], "Splash::None", False


def zones_lit(zones):
    return "[" + ", ".join(f"({lit(r)}, {lit(f)})" for r, f in zones) + "]"


def cone(radius, arc_deg, fraction, unit):
    # The search is centred on the attacker; the engine measures a cone's length from the
    # attacker's centre, so its radius is added (as the hand table did).
    return (
        f"Splash::Cone {{ length: {lit(radius)} + {lit(RADII[unit])}, "
        f"half_angle: {lit(arc_deg / 2.0)} * DEG, fraction: {lit(round(fraction, 4))} }}"
    )


# Turrets' YawRate (degrees per Normal second) from the game's TurretData.xml: Liberty's
# (SC2Mapster/SC2GameData mods/liberty.sc2mod, commit 5bdb2afb), which Void and VoidMulti
# leave as they are for these turrets (VoidMulti changes only the Siege Tank's idle rate).
# The reference dump names each weapon's turret but not its rates. The Phoenix's turret is
# in none of these files: its weapon is generated without one (it aims with the unit).
TURRET_YAW = {
    "SpineCrawler": 360.0,
    "SiegeTankSieged": 360.0,
    "SiegeTank": 720.0,
    "PhotonCannon": 720.0,
    "Immortal": 720.0,
    "Colossus": 999.8437,
    "Hellion": 999.8437,
}
NO_TURRET_DATA = {"Phoenix"}


def turret(w):
    t = w.get("turret")
    if t is None or t in NO_TURRET_DATA:
        return ""
    if t not in TURRET_YAW:
        raise SystemExit(f"weapon {w['name']}: turret {t!r} has no YawRate here (add it from TurretData.xml)")
    return f".turret({lit(TURRET_YAW[t])}, {lit(num(w['arc_slop']))})"


def weapon_lit(unit, w, over=None):
    r = reach(w["target_filters"])
    if r is None:
        return None
    amount, b, splash, suicide = shape(unit, w)
    hits = int(round(float(w["summary"]["hits_on_primary_target"])))
    period, rng = num(w["period"]), num(w["range"])
    if over:
        amount, hits, rng, period = over["damage_per_hit"], over["attacks"], over["range"], over["cooldown"]
        b = {x["against"]: x["damage"] for x in over["bonuses"]}
    speeds = [m["max_speed"] for m in w["summary"]["missiles"] if m.get("max_speed")]
    missile = max(speeds) if w["summary"]["delivery"] == "missile" and speeds else 0.0
    timing = (
        f"timing({lit(num(w['damage_point']))}, {lit(num(w['backswing']))}, {lit(num(w['range_slop']))}, "
        f"{lit(num(w['min_scan_range']))}, [{lit(num(w['random_delay_min']))}, {lit(num(w['random_delay_max']))}], {lit(missile)})"
        f"{turret(w)}"
    )
    return (
        f"            // {w['name']}\n"
        f"            Weapon {{ reach: Reach::{r}, damage: {lit(amount)}, hits: {hits}, bonus: {bonus(b)}, "
        f"cooldown: normal_s({lit(period)}), range: {lit(rng)}, min_range: {lit(num(w['minimum_range']))},\n"
        f"                splash: {splash}, suicide: {str(suicide).lower()},\n"
        f"                timing: {timing} }},\n"
    )


def usable(w):
    """Disabled weapons never fire. Hidden ones are the melee twins of ranged weapons
    (Hydralisk, Roach: same damage at touch range, not modelled), except the Baneling's burst,
    which is its only attack."""
    opts = set(w["options"])
    return "Disabled" not in opts and ("Hidden" not in opts or w["name"] == "VolatileBurst")


def ladder_overlay():
    dump = json.loads((REF / "sc2_unit_data_patch_5.0.9.json").read_text())
    return {u["name"]: u for u in dump["Unit"]}


RADII = {}


def unit_lit(kind, u, over):
    if u is None or u.get("exists") is False or u.get("life_max") is None:
        return f"    // {kind}: not in this data set\n    absent(K::{kind}),\n"
    life, shields, armor = num(u["life_max"]), num(u["shields_max"]), num(u["life_armor"])
    sight, speed = num(u["sight"]), num(u["speed"])
    weapons = [w for w in (u.get("weapons") or []) if usable(w)]
    po = {}
    if over:
        life = over.get("max_health", life)
        shields = over.get("max_shield") or shields
        armor = over.get("armor", armor)
        sight = over.get("sight", sight)
        speed = over.get("speed", speed)
        for pw in over.get("weapons", []):
            po[pw["target_type"]] = pw
    RADII[kind] = num(u.get("radius"), 0.5)
    lits = [x for x in (weapon_lit(kind, w, po.get(reach(w["target_filters"]))) for w in weapons) if x]
    scans = [num(w["min_scan_range"]) for w in weapons if reach(w["target_filters"])]
    flying = u.get("mover") == "Fly"
    e_max = num(u.get("energy_max"))
    e_start = num(u.get("energy_start")) if e_max else 0.0
    regen = (
        f"regen({lit(num(u.get('life_regen_rate')))}, {lit(num(u.get('life_regen_delay')))}, "
        f"{lit(num(u.get('shield_regen_rate')))}, {lit(num(u.get('shield_regen_delay')))}, {lit(num(u.get('energy_regen_rate')))})"
    )
    ws = "&[]" if not lits else "&[\n" + "".join(lits) + "        ]"
    return (
        f"    // {kind}\n"
        f"    UnitSpec {{\n"
        f"        hp: {lit(life)}, shield: {lit(shields)}, armor: {lit(armor)}, attrs: {attrs(u['attributes'] or [])},\n"
        f"        speed: per_normal_s({lit(speed)}), sight: {lit(sight)}, radius: {lit(RADII[kind])}, flying: {str(flying).lower()},\n"
        f"        cliff_walk: {str(u.get('mover') in ('Colossus', 'CliffJumper')).lower()}, energy_max: {lit(e_max)}, energy_start: {lit(e_start)},\n"
        f"        regen: {regen}, scan_range: {lit(max(scans) if scans else 5.0)},\n"
        f"        weapons: {ws},\n"
        f"        ..traits(K::{kind})\n"
        "    },\n"
    )


def table(name, doc, units, overlay=None):
    RADII.clear()
    for kind, data_name in KINDS:
        u = units.get(data_name)
        if u and u.get("life_max") is not None:
            RADII[kind] = num(u.get("radius"), 0.5)
    out = [f"/// {doc}\n", f"pub(in crate::units) static {name}: [UnitSpec; {len(KINDS)}] = [\n"]
    for kind, data_name in KINDS:
        out.append(unit_lit(kind, units.get(data_name), overlay.get(data_name) if overlay else None))
    out.append("];\n")
    return "".join(out)


def main():
    sets = [
        ("LIBERTY", "liberty", "liberty", "Core + Liberty, SC2 4.10 (`units_liberty_4.10.json`).", None),
        ("VOID", "void", "void", "Core + Liberty + Swarm + Void, SC2 4.10 (`units_void_4.10.json`).", None),
        ("LADDER", "ladder", "voidmulti", "VoidMulti at SC2 4.10 (`units_voidmulti_4.10.json`) under python-sc2's 5.0.9 values.", ladder_overlay()),
    ]
    head = [
        "// Generated by tools/gen_units.py from shared/reference/sc2_data: do not edit by hand.\n",
        "// CI regenerates it and fails on any difference. Times are Normal-speed seconds as the\n",
        "// data stores them; `timing(damage point, backswing, range slop, scan range, random delay,\n",
        "// missile speed)`, `.turret(yaw rate, arc slop)` and `regen(life, life delay, shields,\n",
        "// shield delay, energy)` convert.\n\n",
        "use super::super::short::*;\n",
        "use super::super::{Reach, Splash, UnitKind as K, UnitSpec, Weapon, absent, regen, timing, traits};\n",
        "use crate::time::{normal_s, per_normal_s};\n\n",
        "const DEG: f32 = std::f32::consts::PI / 180.0;\n\n",
    ]
    OUT.mkdir(parents=True, exist_ok=True)
    for const, file, source, doc, overlay in sets:
        units = json.loads((REF / "sc2_data" / f"units_{source}_4.10.json").read_text())["units"]
        text = "".join(head) + table(const, doc, units, overlay)
        if "absent(K::" not in text:
            text = text.replace(" absent,", "")
        if "DEG" not in text.split("const DEG", 1)[1].split("\n", 1)[1]:
            text = text.replace("const DEG: f32 = std::f32::consts::PI / 180.0;\n\n", "")
        (OUT / f"{file}.rs").write_text(text.rstrip() + "\n")


if __name__ == "__main__":
    main()
