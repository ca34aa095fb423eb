#!/usr/bin/env python3
"""Builds the project's scenario files (TOML) from the reference map data.

Usage: python3 tools/gen_scenarios.py [REFERENCE_DIR] [OUT_DIR]
Defaults: ../shared/reference/scenarios and engine/scenarios.

The two places where the paper and the source maps disagree follow the paper:
6r_vs_8z keeps the first 8 of the map's 10 Zealots, pvz_ht the first 3 of its 4 Queens.
"""
import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REF = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "reference" / "scenarios"
OUT = Path(sys.argv[2]) if len(sys.argv) > 2 else ROOT / "engine" / "scenarios"

# Paper, appendix "Map Details": what each scenario tests, and where it comes from.
DESCRIPTIONS = {
    "2c_vs_64zg_vlm": "2 Colossi against 64 Zerglings: unit control, terrain usage and kiting (VLM-Attention's version of SMAC's map: 32x32, 300 s).",
    "2m_vs_1z_vlm": "2 Marines against 1 Zealot: kiting a melee unit (VLM-Attention's version of SMAC's map: 32x32, 300 s).",
    "2s_vs_1sc_vlm": "2 Stalkers against a Spine Crawler: alternating aggro (VLM-Attention's version of SMAC's map: 32x32, 300 s).",
    "3s_vs_3z_vlm": "3 Stalkers against 3 Zealots: kiting (VLM-Attention's version of SMAC's map: 32x32, 300 s).",
    "6r_vs_8z": "6 Reapers against 8 Zealots: hit-and-run over terrain.",
    "8m1mv_vs_2st": "8 Marines and a Medivac against 2 sieged Siege Tanks: closing in under splash.",
    "8m2st_vs_35zg4b": "8 Marines and 2 sieged Siege Tanks against 35 Zerglings and 4 Banelings: holding a position.",
    "8m_vs_2pc1wp": "8 Marines against 2 Photon Cannons powered by a phasing Warp Prism: picking the key target.",
    "2s3z_vlm": "2 Stalkers and 3 Zealots on each side: mixed-unit mirror (VLM-Attention's version of SMAC's map: 32x32, 300 s).",
    "3m_vlm": "3 Marines on each side: focus fire (VLM-Attention's version of SMAC's map: 32x32, 300 s).",
    "mixed_units": "Zealot, Immortal, Archon, Stalker and Phoenix against eight different Terran units: target priority.",
    "8m3mr1mv1st_mirror": "Marines, Marauders, a Medivac and a Siege Tank on each side, with Stimpack and Combat Shield.",
    "8s_vs_8m3mr1mv1st": "8 Blink Stalkers against a Terran bio army with a Medivac and a Siege Tank.",
    "8m3mr1mv1st_vs_5s2c": "Terran bio with a Medivac and a Siege Tank against 5 Stalkers and 2 Colossi.",
    "pvz_ht": "Stalkers, Sentries, High Templar and an Archon against a Zergling, Baneling, Ultralisk and Queen army (LLM-PySC2).",
    "MMM_vs_MMM": "Marines, Marauders and a Medivac on each side, agents on both (SMAC's MMM as PvP).",
    "mixed_units_pvp": "Protoss mixed units against Terran mixed units, agents on both sides.",
    "terran_mirror": "Eight different Terran units on each side, agents on both sides.",
    "7s_vs_11m1mv1st": "7 Blink Stalkers against 11 Marines, a Medivac and a Siege Tank, agents on both sides.",
    "8s_vs_8m3mr1mv1st_pvp": "8 Blink Stalkers against a Terran bio army, agents on both sides.",
    "8m3mr1mv1st_mirror_pvp": "Terran bio mirror with a Siege Tank, agents on both sides.",
}
# The paper's six scenarios that share a name with one of SMAC's maps are VLM-Attention's
# maps (`<name>_vlm_attention`): another map size, start and a 300 s limit. SMAC's names mean
# SMAC's maps (engine/scenarios/smac/), so these carry the source map's suffix.
RENAMED = {n: f"{n}_vlm" for n in ("2c_vs_64zg", "2m_vs_1z", "2s3z", "2s_vs_1sc", "3m", "3s_vs_3z")}
KEEP = {("6r_vs_8z", "Zealot"): 8, ("pvz_ht", "Queen"): 3}
# The unit data each map runs: the mod its DocumentHeader depends on, as sc2_data's
# map_overrides.json lists it (Liberty -> liberty, Void -> void, VoidMulti -> ladder).
MODS = {"Mods/Liberty.SC2Mod": "liberty", "Mods/Void.SC2Mod": "void", "Mods/VoidMulti.SC2Mod": "ladder"}
# pvz_ht's map is not among sc2_data's maps: LLM-PySC2's pvz_task6_level3.SC2Map (commit
# 5b4a38a, sha1 30af0e71) was read with mpyq: its DocumentHeader and DocumentInfo name one
# dependency, Mods/Void.SC2Mod, and it ships no data files.
UNLISTED = {"pvz_task6_level3": "void"}
DATA_NOTES = {
    "pvz_task6_level3": "LLM-PySC2's map depends on Mods/Void.SC2Mod (read from its DocumentHeader)",
}


def map_data(source_map):
    if source_map in UNLISTED:
        return UNLISTED[source_map], DATA_NOTES[source_map]
    maps = json.loads((REF.parent / "sc2_data" / "map_overrides.json").read_text())["maps"]
    deps = maps[f"ava/{source_map}"]["declared_dependencies"]
    sets = {MODS[m] for d in deps for m in MODS if d.endswith(m)}
    if len(sets) != 1:
        raise SystemExit(f"{source_map}: dependencies {deps} name no single known mod")
    return sets.pop(), f"the map depends on {deps[0].split(',file:')[-1]}"
RAMP_CHARS = "abcdefghijklmnopqrstuvwxyz"


def start_order(text):
    nums = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", text)]
    if text.startswith("none"):
        return None
    if "random point between" in text:
        return {"kind": "attack_move_random", "from": nums[0:2], "to": nums[2:4]}
    m = re.match(r"at t=(\d+(?:\.\d+)?) s", text)
    delay = float(m.group(1)) if m else 0.0
    pts = re.findall(r"\((-?\d+(?:\.\d+)?),\s*(-?\d+(?:\.\d+)?)\)", text)
    if "attack" in text and pts:
        out = {"kind": "attack_move", "x": float(pts[-1][0]), "y": float(pts[-1][1])}
        if delay:
            out["delay_s"] = delay
        return out
    raise SystemExit(f"cannot read start order {text!r}")


def fmt(v):
    return repr(float(v)) if isinstance(v, float) else str(v)


def terrain(rows_from_y0):
    grid = [[int(v) for v in r.split()] for r in rows_from_y0]
    values = sorted({v for r in grid for v in r if v != 0})
    legend, chars = {}, iter(RAMP_CHARS)
    for v in values:
        if v % 64 == 0:
            legend[v] = str(v // 64)
        else:
            legend[v] = next(chars)
    rows = ["".join("." if v == 0 else legend[v] for v in r) for r in reversed(grid)]
    return legend, rows


def convert(path):
    d = json.loads(path.read_text())
    name = RENAMED.get(d["scenario"], d["scenario"])
    w, h = d["map_size"]
    l, b, r, t = d["playable_bounds_lbrt"]
    if (l, b, r, t) == (0, 0, 0, 0):
        l, b, r, t = 0, 0, w, h
    seen, units = {}, []
    for u in d["units"]:
        key = (name, u["type"])
        seen[key] = seen.get(key, 0) + 1
        if key in KEEP and seen[key] > KEEP[key]:
            continue
        units.append(u)
    units.sort(key=lambda u: u["player"])
    out = [
        f"# {name}: generated by tools/gen_scenarios.py from the source map {d['source_map']!r}.",
        "# Coordinates are map cells, +y up (north); team 1 is the agent side, team 2 the opponent.",
        f'name = "{name}"',
        f'mode = "{d["mode"]}"',
        f'description = "{DESCRIPTIONS[name]}"',
        'objective = "Destroy every enemy unit within 300 seconds of game time."',
        f'source = "{d["source_map"]}"',
        f"# unit data: {map_data(d['source_map'])[1]}",
        f'data = "{map_data(d["source_map"])[0]}"',
        f"map_size = [{w}, {h}]",
        f"playable = [{fmt(float(l))}, {fmt(float(b))}, {fmt(float(r))}, {fmt(float(t))}]",
        "time_limit_s = 300.0",
    ]
    ups = d["upgrades"]
    out.append("upgrades = [")
    for u in ups:
        out.append(f'  {{ team = {u["player"]}, name = "{u["upgrade"]}" }},')
    out.append("]")
    out.append("units = [")
    for u in units:
        out.append(
            f'  {{ type = "{u["type"]}", team = {u["player"]}, x = {u["x"]}, y = {u["y"]}, facing = {u["facing_rad"]} }},'
        )
    out.append("]")
    out.append("")
    out.append("[opponent]")
    out.append('policy = "builtin"')
    so = start_order(d["p2_start_order"])
    out.append(f"# source map: {d['p2_start_order']}")
    if so is None:
        out.append('start = { kind = "none" }')
    else:
        parts = ", ".join(f"{k} = {json.dumps(v) if isinstance(v, str) else v}" for k, v in so.items())
        out.append(f"start = {{ {parts} }}")
    legend, rows = terrain(d["cliff_level_rows_from_y0"])
    out.append("")
    out.append("[terrain]")
    out.append("# Heights in cliff levels; fractional heights are ramp cells. '.' is no ground.")
    out.append("# The first row is the top of the map (highest y), as a screenshot shows it.")
    items = ", ".join(f'"{c}" = {v / 64}' for v, c in legend.items())
    out.append(f"legend = {{ {items} }}")
    out.append("rows = [")
    for row in rows:
        out.append(f'  "{row}",')
    out.append("]")
    (OUT / f"{name}.toml").write_text("\n".join(out) + "\n")
    return name, len(units)


# SMACv2's procedural scenarios (oxwhirl/smacv2, configs sc2_gen_<race>.yaml): each race's
# unit types in the order of its one-hot type bits, their weights, and the types a team may
# not consist of alone; the 32x32 flat map, 200 steps of 8 loops, surrounded_and_reflect
# with p = 0.5, and the five team sizes of its scenario table.
PROCEDURAL = {
    "protoss": (["Stalker", "Zealot", "Colossus"], [0.45, 0.45, 0.1], []),
    "terran": (["Marine", "Marauder", "Medivac"], [0.45, 0.45, 0.1], ["Medivac"]),
    "zerg": (["Zergling", "Hydralisk", "Baneling"], [0.45, 0.45, 0.1], ["Baneling"]),
}
SIZES = [(5, 5), (10, 10), (10, 11), (20, 20), (20, 23)]


def procedural(race, n, m):
    types, weights, exceptions = PROCEDURAL[race]
    name = f"{race}_{n}_vs_{m}"
    q = lambda xs: "[" + ", ".join(json.dumps(x) for x in xs) + "]"
    out = [
        f"# {name}: generated by tools/gen_scenarios.py with SMACv2's settings (sc2_gen_{race}.yaml).",
        "# Coordinates are map cells, +y up (north); team 1 is the agent side, team 2 the opponent.",
        "# Units are drawn for every episode from its seed: see [generate].",
        f'name = "{name}"',
        'mode = "pve"',
        f'description = "{n} vs {m} {race.capitalize()} units drawn every episode, surrounded or reflected starts (SMACv2)."',
        'objective = "Destroy every enemy unit within 71 seconds of game time."',
        f'source = "smacv2:10gen_{race}"',
        "# unit data: SMACv2's maps depend on Mods/Liberty.SC2Mod",
        'data = "liberty"',
        "map_size = [32, 32]",
        "playable = [0.0, 0.0, 32.0, 32.0]",
        "# SMACv2's episode limit: 200 steps of 8 game loops.",
        "time_limit_s = 71.4286",
        "units = []",
        "",
        "[opponent]",
        'policy = "builtin"',
        "# attack-moves to team 1's drawn start",
        "",
        "[generate]",
        f"n_units = {n}",
        f"n_enemies = {m}",
        f"unit_types = {q(types)}",
        f"weights = {q(weights)}",
        f"exception_unit_types = {q(exceptions)}",
        'start_positions = "surrounded_and_reflect"',
        "p = 0.5",
    ]
    (OUT / f"{name}.toml").write_text("\n".join(out) + "\n")
    return name


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    for p in sorted(REF.glob("*.json")):
        name, n = convert(p)
        print(f"{name}: {n} units")
    for race in PROCEDURAL:
        for n, m in SIZES:
            print(f"{procedural(race, n, m)}: drawn")


if __name__ == "__main__":
    main()
