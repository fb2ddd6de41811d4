"""cube_rebuild_probe's run: refit against rebuild after every object moved once."""

import json


def _us(x):
    return f"{x / 1000:.1f} ms" if x >= 1000 else f"{x:.0f} µs"


def rebuild_text(path):
    """Per scene: the refitted tree's quality, the build's room, what a walk loses on the
    refitted tree (predicted by the library, measured), what the library does with the default
    budget at the first update and what was cheaper for the update and one walk, and the sampled
    object queries' box tests after the motion over before it."""
    with open(path) as f:
        scenes = json.load(f)["scenes"]
    lines = [
        "### Refit or rebuild after one motion (`cube_rebuild_probe`)",
        "",
        "From `rebuild_probe.json`: every object of the scene moved once by up to its typical "
        "size (or turned by up to 10 degrees about the centre), then `update()` on a manager "
        "that only refits, against a manager built on the moved objects (register + `setup()`, "
        "best of 5; self-collides best of 7). Loss = what one self-collide of the refitted tree "
        "costs more than one of the rebuilt tree, in builds: predicted by the library "
        "(`Config::rebuild_budget`'s prediction, from the quality and the room: the last "
        "build's leaves' surface area over their objects') and measured. The library, with "
        "the default budget of 1, rebuilds at the first update if the predicted loss passes 1. "
        "Cheaper: of update + one self-collide of the refitted tree and build + one of the "
        "rebuilt tree, by how much. Sampled queries: the box tests of object queries of every "
        "256th object on the refitted tree over the same before the motion, and the "
        "self-collide's slowdown beside it.",
        "",
        "| scene | objects | quality | room | update (refit) | build | self-collide refitted / "
        "rebuilt | predicted loss | measured loss | the library | cheaper | sampled queries "
        "after / before |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---:|",
    ]
    for s in scenes:
        r = s["walk_refitted_us"] / s["walk_rebuilt_us"]
        refit_cost = s["update_us"] + s["walk_refitted_us"]
        rebuild_cost = s["build_us"] + s["walk_rebuilt_us"]
        if refit_cost <= rebuild_cost:
            cheaper = f"refit, by {100 * (rebuild_cost / refit_cost - 1):.0f}%"
        else:
            cheaper = f"rebuild, by {100 * (refit_cost / rebuild_cost - 1):.0f}%"
        library = "rebuild" if s["predicted_loss"] > 1 else "refit"
        sampled = s["sample_tests_after"] / s["sample_tests_before"]
        lines.append(
            f"| {s['scene']} | {s['objects']:,} | {s['quality']:.2f} | {s['room']:.2f} | "
            f"{_us(s['update_us'])} | {_us(s['build_us'])} | "
            f"{_us(s['walk_refitted_us'])} / {_us(s['walk_rebuilt_us'])} ({r:.2f}x) | "
            f"{s['predicted_loss']:.2f} | {s['measured_loss']:.2f} | {library} | {cheaper} | "
            f"{sampled:.2f}x |")
    return "\n".join(lines) + "\n"
