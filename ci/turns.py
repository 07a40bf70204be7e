#!/usr/bin/env python3
"""What a pixel's rays cost a vector of lavapipe's 8 lanes, turn by turn.

The kernels trace a pixel's rays one walk a turn of the tracing loop
(shaders/trace.glsl), and a turn ends when its slowest lane's walk does
(`bench --lanes`, "all in step", counts the same over every pixel). This
samples 4x2 blocks of pixels (a vector's, `tile_pixel`), takes each
pixel's walks from `raycast trace --json`, and prints, per block, the
passes the vector pays and its turns: as the kernels take the rays, and
as they would be were a surface's shadow rays one turn ("shadows"), or
its shadow rays and its mirror ray one turn ("shadows and mirror"): what
letting a lane start its next ray inside the walk's loop would save in
passes and turns, before the cost of doing so.

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
    out = subprocess.run(
        [raycast, "trace", "--pixel", f"{pixel[0]},{pixel[1]}", scene, "--json", *options],
        capture_output=True, text=True, check=True,
    ).stdout
    steps = json.loads(out)["steps"]
    return [(s["kind"], s["passes"]) for s in steps if s["kind"] in ("camera", "shadow", "mirror", "refract")]


def turns(rays, fuse):
    """A pixel's turns' passes: each walk its own turn, or fused as `fuse` says."""
    out, prev = [], None
    for kind, passes in rays:
        joins = (fuse == "shadows" and kind == "shadow" and prev == "shadow") or (
            fuse == "shadows and mirror" and (kind == "mirror" or (kind == "shadow" and prev == "shadow"))
        )
        if joins and out:
            out[-1] += passes
        else:
            out.append(passes)
        prev = kind
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
    for fuse in ("none", "shadows", "shadows and mirror"):
        paid = needed = count = 0
        for b in range(args.blocks):
            lanes = [turns(r, fuse) for r in rays[8 * b:8 * b + 8]]
            n = max(len(t) for t in lanes)
            paid += sum(max(t[i] if i < len(t) else 0 for t in lanes) for i in range(n))
            needed += sum(sum(t) for t in lanes)
            count += n
        label = "as the kernels take them" if fuse == "none" else f"one turn for a surface's {fuse}"
        print(
            f"  {label}: {paid / args.blocks:.2f} passes and {count / args.blocks:.2f} turns a block; "
            f"lane use {needed / (8 * paid):.3f}"
        )


if __name__ == "__main__":
    main()
