"""What the project's scripts share about their command lines: -h or --help prints the script's
usage (its docstring) and exits 0; an option it does not know, an option with no value, or a
hedgefit that is not an executable is refused in one line, exit 2."""
import os
import sys


def _name():
    return os.path.splitext(os.path.basename(sys.argv[0]))[0]


def check_args(doc, flags=(), with_value=()):
    """sys.argv[1:] checked against the script's options: `flags` stand alone, `with_value` take
    the next word; any other word that starts with '-' is refused. Words that do not start with '-'
    are the script's own positional arguments and are not checked here."""
    args = sys.argv[1:]
    if "-h" in args or "--help" in args:
        print(doc.strip())
        sys.exit(0)
    i = 0
    while i < len(args):
        a = args[i]
        if a in with_value:
            if i + 1 >= len(args):
                refuse(f"{a} needs a value")
            i += 2
            continue
        if a.startswith("-") and a not in flags:
            known = ", ".join(list(flags) + list(with_value) + ["--help"])
            refuse(f"{a} is not an option ({known})")
        i += 1


def require_executable(exe):
    """`exe` (hedgefit's path, as given) must be a file this user can run."""
    if not (os.path.isfile(exe) and os.access(exe, os.X_OK)):
        refuse(f"{exe} is not an executable: give hedgefit's path, or build it first (cmake --build build)")


def refuse(why):
    print(f"{_name()}: {why}", file=sys.stderr)
    sys.exit(2)
