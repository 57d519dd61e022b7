#!/usr/bin/env python3
"""Checks that the library's folders are the stages of the pipeline: a file under lib/src/STAGE
or lib/include/qjulia/STAGE includes only headers of its own stage or of a lower one, in the order
base < field < grid < surface < mesh < io < render < pipeline (docs/design.md, section 10), and a
public header includes only public headers. Prints every include from a stage up to a higher one
and the count of includes between stages; exits 1 on a violation.

usage: scripts/check_layers.py [ROOT]   (ROOT: the repository, default: this script's parent)
"""
import pathlib
import re
import sys

STAGES = ["base", "field", "grid", "surface", "mesh", "io", "render", "pipeline"]
RANK = {stage: i for i, stage in enumerate(STAGES)}

# Includes up the stages that are known and due to move, each with the reason. An entry that no
# longer matches an include is itself an error, so the list cannot outlive the move.
KNOWN = {}

INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')


def stage_of_include(name, own_stage):
    """The stage of a quoted include, or None for a header outside the library."""
    parts = name.split("/")
    if parts[0] == "qjulia":
        parts = parts[1:]
    if len(parts) == 1:
        return own_stage  # a header beside the file
    return parts[0] if parts[0] in RANK else None


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent)
    errors, counts, used_known = [], {}, set()
    for top in ("lib/src", "lib/include/qjulia"):
        base = root / top
        for path in sorted(p for p in base.rglob("*") if p.is_file()):
            rel = path.relative_to(root).as_posix()
            stage = path.relative_to(base).parts[0]
            if stage not in RANK:
                errors.append(f"{rel}: not in a stage folder ({', '.join(STAGES)})")
                continue
            lines = path.read_text(errors="replace").splitlines()
            for number, line in enumerate(lines, 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                name = m.group(1)
                target = stage_of_include(name, stage)
                if target is None:
                    continue
                if top == "lib/include/qjulia" and not name.startswith("qjulia/"):
                    errors.append(f"{rel}:{number}: a public header includes the internal {name}")
                counts[(stage, target)] = counts.get((stage, target), 0) + 1
                if RANK[target] > RANK[stage]:
                    if (rel, name) in KNOWN:
                        used_known.add((rel, name))
                        print(f"{rel}:{number}: known: {stage} includes {name} ({target}): "
                              f"{KNOWN[(rel, name)]}")
                    else:
                        errors.append(f"{rel}:{number}: {stage} includes {name}, of the higher "
                                      f"stage {target}")
    for rel, name in sorted(set(KNOWN) - used_known):
        errors.append(f"{rel}: the known include of {name} is gone: remove it from KNOWN")
    print("includes between stages (from -> to: count):")
    for (a, b), n in sorted(counts.items(), key=lambda e: (RANK[e[0][0]], RANK[e[0][1]])):
        if a != b:
            print(f"  {a:9s} -> {b:9s} {n}")
    for e in errors:
        print("error:", e)
    print(f"check_layers: {len(errors)} error(s)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
