#!/usr/bin/env python3
"""The rooms' rules (docs/architecture.md), checked on the sources:
  1. a room includes only the rooms it may use (the arrows of the table);
  2. across rooms, only public headers are included;
  3. no public header includes a third-party library's header (CGAL, PCL,
     Embree, FLANN, OSMesa, TBB, CLI11), so none leaks into its users;
  4. no include cycle, between files or between rooms.
Usage: check_rooms.py REPOSITORY_ROOT. Prints every violation; exit 1 if any."""
import os
import re
import sys

# Room -> rooms it may include (itself always).
ALLOWED = {
    "core": set(),
    "adapters/embree": {"core"},
    "adapters/flann": {"core"},
    "adapters/cgal": {"core"},
    "adapters/pcl": {"core"},
    "adapters/osmesa": {"core"},
    "adapters/meshopt": {"core"},
    "adapters/draco": {"core"},
    "format": {"core"},
    "ingest": {"core", "adapters/pcl", "adapters/cgal", "adapters/flann", "adapters/embree"},
    "reconstruct": {"core", "adapters/cgal", "adapters/flann", "adapters/meshopt"},
    "bake": {"core", "format"},
    "render": {"core", "format", "adapters/osmesa", "adapters/flann"},
    "report": {"core"},
    "export": {"core", "format", "adapters/draco"},
    "pipeline": {"core", "format", "ingest", "reconstruct", "bake", "render", "report", "export",
                 "adapters/embree", "adapters/flann"},
    "cli": {"core", "format", "ingest", "reconstruct", "bake", "render", "report", "export", "pipeline"},
}

# The headers other rooms may include.
PUBLIC = {
    "core": None,  # every header of core is public
    "adapters/embree": {"embree_ray_caster.h"},
    "adapters/flann": {"flann_search.h"},
    "adapters/cgal": {"cgal_jobs.h"},
    "adapters/pcl": {"pcl_points.h"},
    "adapters/osmesa": {"gl_context.h"},
    "adapters/meshopt": {"meshopt_simplify.h"},
    "adapters/draco": {"draco_mesh.h"},
    "format": {"format.h"},
    "ingest": {"ingest.h"},
    "reconstruct": {"reconstruct.h"},
    "bake": {"bake.h"},
    "render": {"render.h"},
    "report": {"report.h"},
    "export": {"export.h"},
    "pipeline": {"pipeline.h", "bake_seams.h", "progress.h"},
    "cli": set(),
}

LIBRARY = re.compile(r"#include\s*<(CGAL/|pcl/|embree3/|flann/|GL/osmesa|tbb/|CLI/|meshoptimizer\.h|draco/)")
LOCAL = re.compile(r'#include\s*"([^"]+)"')


def room_of(path):
    parts = path.split("/")
    if parts[0] == "adapters" and len(parts) > 2:
        return "adapters/" + parts[1]
    return parts[0] if parts[0] in ALLOWED else None


def sources(root):
    for room in ALLOWED:
        folder = os.path.join(root, room)
        for dirpath, _, files in os.walk(folder):
            for name in files:
                if name.endswith((".h", ".cpp")):
                    path = os.path.relpath(os.path.join(dirpath, name), root)
                    if room_of(path) == room:
                        yield path


def find_cycle(graph):
    """A cycle of the directed graph as a list of nodes, or None."""
    white, grey, black = 0, 1, 2
    colour = {node: white for node in graph}
    stack = []

    def visit(node):
        colour[node] = grey
        stack.append(node)
        for successor in sorted(graph.get(node, ())):
            if colour.get(successor, black) == grey:
                return stack[stack.index(successor):] + [successor]
            if colour.get(successor) == white:
                found = visit(successor)
                if found:
                    return found
        stack.pop()
        colour[node] = black
        return None

    for node in sorted(graph):
        if colour[node] == white:
            found = visit(node)
            if found:
                return found
    return None


def main(root):
    problems = []
    files = {}
    for path in sources(root):
        with open(os.path.join(root, path), encoding="utf-8") as f:
            files[path] = f.read()
    file_graph = {path: set() for path in files}
    room_graph = {room: set() for room in ALLOWED}
    for path, text in files.items():
        room = room_of(path)
        for included in LOCAL.findall(text):
            target = room_of(included)
            if target is None:
                continue  # tests/ helpers and the like are not rooms
            file_graph[path].add(included)
            if target == room:
                continue
            room_graph[room].add(target)
            if target not in ALLOWED[room]:
                problems.append(f"{path}: {room} may not include {target} ({included})")
            public = PUBLIC[target]
            if public is not None and os.path.basename(included) not in public:
                problems.append(f"{path}: includes {included}, an internal header of {target}")
        is_public_header = path.endswith(".h") and (PUBLIC[room] is None or os.path.basename(path) in PUBLIC[room])
        if is_public_header and room != "adapters/osmesa":
            for match in LIBRARY.finditer(text):
                problems.append(f"{path}: a public header includes a library header <{match.group(1)}...>")
    for graph, kind in ((file_graph, "files"), (room_graph, "rooms")):
        cycle = find_cycle(graph)
        if cycle:
            problems.append(f"include cycle between {kind}: " + " -> ".join(cycle))
    for problem in problems:
        print(problem)
    print(f"{len(files)} files in {len(ALLOWED)} rooms: {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
