#!/usr/bin/env python3
"""No function in the product's C++ is longer than LIMIT lines (from its signature's opening
brace to its closing one): longer ones are split into named steps. Reads every tracked .cpp
and .h under the product's folders (tests and benchmarks included), strips comments and
strings, and follows braces: a brace that opens after a signature (a closing parenthesis, not
a control statement, a class or a namespace) starts a function, lambdas inside it count as its
lines. Prints each function over the limit as path:line: name (lines) and exits 1 if any."""
import re
import subprocess
import sys
from pathlib import Path

LIMIT = 120
FOLDERS = ("apps", "bench", "lod", "protocol", "renderer", "server", "storage", "tests", "view")
NOT_A_FUNCTION = re.compile(r"\b(if|for|while|switch|catch|namespace|class|struct|enum|union|do|else|try)\b|=\s*$|^\s*\[|\]\s*\(|\)\s*->\s*[\w:<>]+\s*$|\]\s*$")


def strip(text):
    """Comments, string and character literals blanked out, line breaks kept."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            end = ')' + (m.group(1) if m else '') + '"'
            j = text.find(end, i)
            j = n if j < 0 else j + len(end)
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def long_functions(path):
    text = strip(path.read_text(errors="replace"))
    found = []
    stack = []  # per open brace: (start line, name) for a function, None otherwise
    head = []   # text since the last ; { or } at this level
    line = 1
    for c in text:
        if c == "\n":
            line += 1
        if c == "{":
            signature = "".join(head).strip()
            inside_function = any(s is not None for s in stack)
            is_function = not inside_function and signature.endswith(")") or (
                not inside_function and re.search(r"\)\s*(const|noexcept|override|final|mutable|\s)*(->\s*[\w:<>,\s*&]+)?$", signature))
            if is_function and NOT_A_FUNCTION.search(signature.split("(")[0] + " " + signature[-40:]) and not re.match(r"^[\w:~<>,\s*&]+\(", signature):
                is_function = False
            if is_function:
                name = re.findall(r"([\w:~]+)\s*\(", signature)
                stack.append((line, name[0] if name else "?"))
            else:
                stack.append(None)
            head = []
        elif c == "}":
            if stack:
                top = stack.pop()
                if top is not None:
                    start, name = top
                    if line - start + 1 > LIMIT:
                        found.append((start, name, line - start + 1))
            head = []
        elif c == ";":
            head = []
        else:
            head.append(c)
    return found


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    try:
        listed = subprocess.run(["git", "-C", str(root), "ls-files", "*.cpp", "*.h"], capture_output=True, text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        listed = [str(p.relative_to(root)) for p in root.rglob("*") if p.suffix in (".cpp", ".h")]
    files = [f for f in listed if f.split("/")[0] in FOLDERS and "node_modules" not in f]
    bad = []
    for f in files:
        if (root / f).is_file():
            bad += [(f, *x) for x in long_functions(root / f)]
    for f, start, name, length in sorted(bad):
        print(f"{f}:{start}: {name} ({length} lines, over {LIMIT})")
    print(f"function length: {len(bad)} functions over {LIMIT} lines in {len(files)} files")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
