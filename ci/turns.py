#!/usr/bin/env python3
"""What a pixel's rays cost a vector of lavapipe's 8 lanes, turn by turn.

A vector's lanes step together: a walk that ends early waits for its
neighbours' in the same step (`bench --lanes`, "all in step", counts the
kernels' own steps over every pixel). This samples 4x2 blocks of pixels
(a vector's, `tile_pixel`), takes each pixel's walks from `raycast trace
--json`, and prints the passes and steps a block pays under four ways of
stepping a pixel's rays (shaders/trace.glsl):

- "a walk a step": every ray through one walk call, the k-th walk of each
  lane together (the kernels until 2026-12-07);
- "the kernels": a turn for each camera, mirror or refracted ray, then
  the light loop, a light point a step, its shadow ray walked there;
- "shadows in one step": a turn's ray a step, then all its surface's
  shadow rays one after another within one step (not built);
- "shadows and mirror in one step": a surface's shadow rays and its
  mirror ray walked one after another within one step, as a lane that
  started its next ray inside the walk's loop would (not built).

    ci/turns.py [--blocks N] [--raycast BIN] SCENE [raycast options]...

e.g. `ci/turns.py gen:recursive-spheres:10 --assets $CORPUS`.
Deterministic (the blocks are drawn from a fixed seed).
"""
import argparse
import json
import random
import subprocess
from concurrent.futures import ThreadPoolExecutor


def walks(raycast, scene, options, pixel):
    """A pixel's walks as (kind, turn, slot, passes), as Walk::of_steps keys them."""
    out = subprocess.run(
        [raycast, "trace", "--pixel", f"{pixel[0]},{pixel[1]}", scene, "--json", *options],
        capture_output=True, text=True, check=True,
    ).stdout
    found, turn, slot = [], -1, 0
    for s in json.loads(out)["steps"]:
        if s["kind"] in ("camera", "mirror", "refract"):
            turn, slot = turn + 1, 0
            found.append((s["kind"], turn, 0, s["passes"]))
        elif s["kind"] == "light":
            slot += 1
        elif s["kind"] == "shadow":
            found.append(("shadow", turn, slot, s["passes"]))
    return found


def steps(walks, way):
    """A pixel's steps as {key: passes}: the block pays each key's most."""
    out = {}
    for i, (kind, turn, slot, passes) in enumerate(walks):
        if way == "a walk a step":
            key = i
        elif way == "the kernels":
            key = (turn, slot)
        elif kind == "shadow":
            key = (turn, 1)  # after the turn's ray, all its shadow rays in one step
        elif way == "shadows in one step":
            key = (turn, 0)  # every turn's ray a step of its own
        elif kind == "mirror":
            key = (turn - 1, 1)  # and the mirror ray after them, in the same step
        else:
            key = (turn, 0)
        out[key] = out.get(key, 0) + passes
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--blocks", type=int, default=400)
    p.add_argument("--raycast", default="build/raycast")
    p.add_argument("--width", type=int, default=512)
    p.add_argument("--height", type=int, default=384)
    p.add_argument("scene")
    args, options = p.parse_known_args()
    options += ["--width", str(args.width), "--height", str(args.height)]
    rng = random.Random(1)
    blocks = [(rng.randrange(0, args.width - 3, 4), rng.randrange(0, args.height - 1, 2)) for _ in range(args.blocks)]
    pixels = [(x + (k & 3), y + (k >> 2)) for x, y in blocks for k in range(8)]
    with ThreadPoolExecutor(4) as pool:
        rays = list(pool.map(lambda px: walks(args.raycast, args.scene, options, px), pixels))
    print(f"{args.scene}: {args.blocks} blocks of 4x2 pixels")
    for way in ("a walk a step", "the kernels", "shadows in one step", "shadows and mirror in one step"):
        paid = needed = count = 0
        for b in range(args.blocks):
            lanes = [steps(r, way) for r in rays[8 * b:8 * b + 8]]
            keys = set().union(*lanes)
            paid += sum(max(l.get(k, 0) for l in lanes) for k in keys)
            needed += sum(sum(l.values()) for l in lanes)
            count += len(keys)
        print(
            f"  {way}: {paid / args.blocks:.2f} passes and {count / args.blocks:.2f} steps a block; "
            f"lane use {needed / (8 * paid):.3f}"
        )


if __name__ == "__main__":
    main()
