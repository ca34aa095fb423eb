"""Draws docs/img/foxglove-layout.png: what docs/foxglove-layout.json shows, from a recording's
live-view channels (a `launch` with `record:` adds them), decoded with Foxglove's own protobuf
schema classes (pip: foxglove-schemas-protobuf, mcap, pillow).

    python3 tools/foxglove_picture.py 3m.mcap docs/img/foxglove-layout.png [STEP]

The panels are drawn the way Foxglove's are laid out (screen with its image annotations,
minimap, a top-down view of the 3D scene's entities, the log, the status), not screenshots
of the app, which is not available here.
"""

import json
import sys

from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader
from PIL import Image, ImageDraw

TYPES = {"screen_image": RawImage, "minimap_image": RawImage, "screen_annotations": ImageAnnotations, "scene_update": SceneUpdate, "log_lines": Log, "episode_status": None}
KIND = {"screen_image": "screen", "minimap_image": "minimap", "screen_annotations": "annotations", "scene_update": "scene", "log_lines": "log", "episode_status": "status"}


def rgb(c):
    return tuple(int(255 * v) for v in (c.r, c.g, c.b))


def main(path, out, at_step):
    frames = {}
    logs = []
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            if not channel.topic.startswith("/avacraft/live/"):
                continue
            name = channel.topic.rsplit("/", 1)[1]
            kind = KIND[name]
            if kind == "status":
                st = json.loads(message.data)
                if st["episode"] == 0:
                    frames.setdefault(st["step"], {})["status"] = st
                    frames[st["step"]]["t"] = message.log_time
                continue
            msg = TYPES[name]()
            msg.ParseFromString(message.data)
            if kind == "log":
                logs.append((message.log_time, msg))
            else:
                frames.setdefault(("t", message.log_time), {})[kind] = msg
    by_time = {k[1]: v for k, v in frames.items() if isinstance(k, tuple)}
    step = min(at_step, max(s for s in frames if isinstance(s, int)))
    status = frames[step]["status"]
    panels = by_time[frames[step]["t"]]
    screen, minimap = panels["screen"], panels["minimap"]
    W, H = 1280, 720
    img = Image.new("RGB", (W, H), (30, 30, 36))
    d = ImageDraw.Draw(img)
    # Left: screen with its annotations, scaled 2x, then the minimap.
    s = Image.frombytes("RGB", (screen.width, screen.height), screen.data).resize((screen.width * 2, screen.height * 2), Image.NEAREST)
    img.paste(s, (0, 0))
    for c in panels["annotations"].circles:
        x, y, r = 2 * c.position.x, 2 * c.position.y, c.diameter
        d.ellipse([x - r, y - r, x + r, y + r], outline=rgb(c.outline_color), width=int(2 * c.thickness))
    for t in panels["annotations"].texts:
        d.text((2 * t.position.x, 2 * t.position.y), t.text, fill=(255, 255, 255))
    m = Image.frombytes("RGB", (minimap.width, minimap.height), minimap.data)
    img.paste(m, (8, screen.height * 2 + 8))
    d.text((m.width + 16, screen.height * 2 + 8), "Image: /avacraft/live/minimap_image", fill=(200, 200, 200))
    d.text((8, 4), "Image: /avacraft/live/screen_image + /avacraft/live/screen_annotations", fill=(255, 255, 0))
    # Right top: the 3D scene seen from above.
    x0, y0, side = 660, 20, 300
    d.rectangle([x0, y0, x0 + side, y0 + side], fill=(18, 18, 24), outline=(90, 90, 90))
    d.text((x0, y0 + side + 4), "3D: /avacraft/live/scene_update (top view)", fill=(200, 200, 200))
    pos = [(e, e.cylinders[0]) for e in panels["scene"].entities if e.cylinders]
    xs = [c.pose.position.x for _, c in pos] or [0]
    ys = [c.pose.position.y for _, c in pos] or [0]
    cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
    scale = side / max(8.0, max(max(xs) - min(xs), max(ys) - min(ys)) + 6)
    for e, c in pos:
        px, py = x0 + side / 2 + (c.pose.position.x - cx) * scale, y0 + side / 2 - (c.pose.position.y - cy) * scale
        r = c.size.x / 2 * scale
        d.ellipse([px - r, py - r, px + r, py + r], fill=rgb(c.color))
        if e.texts:
            d.text((px + r + 2, py - 6), e.texts[0].text, fill=(230, 230, 230))
    # Right bottom: the log up to this step and the status.
    t_now = frames[step]["t"]
    lines = [f"[{l.name}] {l.message}" for t, l in logs if t <= t_now][-14:]
    d.text((x0, 350), "Log: /avacraft/live/log_lines", fill=(255, 255, 0))
    for i, line in enumerate(lines):
        d.text((x0, 368 + 14 * i), line[:80], fill=(220, 220, 220))
    d.text((x0, 580), "Raw Messages: /avacraft/live/episode_status", fill=(255, 255, 0))
    for i, (k, v) in enumerate(status.items()):
        d.text((x0, 598 + 13 * i), f"{k}: {v}", fill=(220, 220, 220))
    img.save(out)
    print(f"{out}: step {step} of episode 0")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 20)
