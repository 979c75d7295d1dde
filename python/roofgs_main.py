"""`python -m roofgs`: the command-line tools installed with the roofgs module (installed as roofgs/__main__.py).

  python -m roofgs                  lists the tools, where they are and what each does
  python -m roofgs TOOL [ARGS...]   runs rgs-TOOL with ARGS (TOOL: convert, info, render, audit, view; the full
                                    name rgs-convert works too), e.g. python -m roofgs convert scene.ply scene.rgs
Exit status: the tool's; 2 for an unknown tool or one that is not installed.
"""
import os
import shutil
import sys
import sysconfig

TOOLS = {
    "convert": "any scene to .rgs, PLY, SPZ, GLB or SOG (rate control, archive profile, LOD)",
    "info": "a scene's format, Gaussians, SH degree, bounds and size; a .rgs file's sections (--check)",
    "render": "render a scene's views to images on the CPU reference (or CUDA)",
    "audit": "compare conversions of a scene against the source, with an HTML report",
    "view": "serve a scene to a web browser (when built with the viewer)",
}


def tool_path(name):
    """The installed rgs-NAME: in this environment's scripts folder, else the user's, else on PATH; or None."""
    exe = f"rgs-{name}"
    folders = [sysconfig.get_path("scripts")]
    try:
        folders.append(sysconfig.get_path("scripts", f"{os.name}_user"))
    except KeyError:
        pass
    for folder in folders:
        path = os.path.join(folder, exe)
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    return shutil.which(exe)


def main(argv):
    if not argv or argv[0] in ("-h", "--help"):
        print("python -m roofgs TOOL [ARGS...] runs rgs-TOOL, installed with the roofgs module:")
        for name, what in TOOLS.items():
            path = tool_path(name)
            print(f"  {name:<8} {what}\n           {path or 'not installed'}")
        print("Each tool's options: python -m roofgs TOOL --help")
        return 0
    name = argv[0][len("rgs-"):] if argv[0].startswith("rgs-") else argv[0]
    if name not in TOOLS:
        print(f"python -m roofgs: unknown tool '{argv[0]}'; tools: {', '.join(TOOLS)}", file=sys.stderr)
        return 2
    path = tool_path(name)
    if path is None:
        print(f"python -m roofgs: rgs-{name} is not installed (the viewer needs Boost and libturbojpeg at build time)",
              file=sys.stderr)
        return 2
    os.execv(path, [f"rgs-{name}"] + argv[1:])
    return 1  # not reached: execv replaces the process or raises


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
