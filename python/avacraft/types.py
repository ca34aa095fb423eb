"""The shapes of typed actions and of the VLM unit list, as Python dicts (TypedDicts for
editors and type checkers; at run time they are plain dicts).

An action names a unit by its tag (1-based, as screenshots, texts and unit lists show it)::

    {"unit": 1, "command": {"kind": "attack", "target": 4}}
    {"unit": 2, "command": {"kind": "move_grid", "x": 3, "y": 7}}      # cell of the 10x10 grid
    {"unit": 2, "command": {"kind": "move_dir", "dir": "up"}}         # up, down, left, right
    {"unit": 3, "command": {"kind": "move_to", "to": {"x": 12.5, "y": 20.0}}}
    {"unit": 3, "command": {"kind": "attack_move_to", "to": {"x": 12.5, "y": 20.0}}}
    {"unit": 1, "command": "stop"}                                     # also "hold", "no_op"
    {"unit": 5, "command": {"kind": "ability", "ability": "stimpack", "target": {"kind": "none"}}}
    {"unit": 6, "command": {"kind": "ability", "ability": "heal", "target": {"kind": "unit", "unit": 2}}}
    {"unit": 7, "command": {"kind": "ability", "ability": "psi_storm", "target": {"kind": "point", "to": {"x": 9, "y": 9}}}}

A malformed action (unknown kind, missing or mistyped field, a tag of 0) raises
`AvacraftError` naming the action's position and the field; an action the game refuses (a
dead or unseen target, a unit that cannot move) is reported per action and the unit keeps its
order.
"""

from __future__ import annotations

from typing import Any, Literal, Optional, TypedDict, Union


class Point(TypedDict):
    x: float
    y: float


class CommandDict(TypedDict, total=False):
    kind: Literal["no_op", "stop", "hold", "attack", "move_grid", "move_dir", "move_to", "attack_move_to", "ability"]
    target: Any  # attack: a unit tag; ability: {"kind": "none" | "unit" | "point", ...}
    x: int
    y: int
    dir: Literal["up", "down", "left", "right"]
    to: Point
    ability: str


Command = Union[CommandDict, Literal["no_op", "stop", "hold"]]


class Action(TypedDict):
    unit: int
    command: Command


class UnitInfo(TypedDict):
    """One unit of the VLM unit list (every living unit a team knows of)."""

    tag: int
    name: str  # "Marine_1": base type and number within its team
    type: str
    team: int  # 1 or 2
    own: bool
    x: float
    y: float
    grid: list[int]  # [x, y] cell of the 10x10 movement grid, (1, 1) top left
    hp: float
    max_hp: float
    shield: float
    max_shield: float
    energy: float
    max_energy: float
    speed: float
    weapon_cooldown_s: float
    order: dict[str, Any]  # {"kind": "idle" | "hold" | "move" | "attack_move" | "attack", ...}
    activity: str
    target: Optional[int]
    flags: Any
    buffs: Any
    abilities: list[dict[str, Any]]  # own units only
