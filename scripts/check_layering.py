#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Checks the house rules a compiler does not: the module layering of docs/design.md, the file
length limit and the function length limit. Run by scripts/test.sh (so by CI); exits non-zero
naming every breach.

Layering: a module's headers (include/plumb/<module>) and sources (src/<module>) include `core`
and the modules below it in the stack, nothing above or beside it; `io` sits beside the stack and
includes `core` only, and only the modules of IO_USERS (the top of the stack) include it. The includes that run against it today are listed in KNOWN_EXCEPTIONS with
the reason; a new one fails, and so does an exception that no longer occurs (so the list shrinks
as the code is fixed).

Length: no source or header over MAX_LINES lines; the files over it today are listed in
LONG_FILES with their length, which they may not exceed.

Function length: no function body in include/**/*.hpp, src/**/*.{cpp,hpp}, examples/**/*.cpp,
bench/**/*.cpp, fuzz/**/*.cpp or python/**/*.{cpp,hpp} over MAX_FUNCTION_LINES lines, counted from
the first line of its declaration (template header and return type included) to its closing brace. A lambda or a local
class is part of the function it sits in. The functions over the limit today are listed in
LONG_FUNCTIONS as "path:name" (name qualified by its classes, e.g. World::World) with their length,
which they may not exceed; an entry that is no longer over the limit fails too, so the list
shrinks as functions are split. The functions are found by a brace-matching scanner, not a parser
(see `functions`): comments, literals and preprocessor lines are blanked, and a `{` at namespace or
class scope opens a function when the tokens before it end a signature: a parameter list, then
only qualifiers (const, noexcept, override, final, ...), a trailing return type or a constructor's
initializer list. A declaration it cannot follow (unbalanced braces) is reported as a breach.
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent

# The stack, top to bottom; a module may include modules in the rows below its own.
STACK = [
    ["app"],
    ["pipeline"],
    ["sim"],
    ["registration", "segmentation", "calibration", "optim"],
    ["features", "scan2d", "loam"],
    ["search", "filters", "imu"],
    ["bim", "eval"],
    ["core"],
]
BESIDE = {"io": {"core"}}
# The modules that may include `io` besides the stack below them: they read and write the files whose
# data the modules below take and give.
IO_USERS = {"app"}

# (module, included module) -> why the include is there today.
KNOWN_EXCEPTIONS = {
}

MAX_LINES = 700
# File -> its length today (may shrink, may not grow).
LONG_FILES = {
}

MAX_FUNCTION_LINES = 150
# "path:function" -> its length today (may shrink, may not grow; removed once within the limit).
LONG_FUNCTIONS = {
}
FUNCTION_GLOBS = ("include/**/*.hpp", "src/**/*.cpp", "src/**/*.hpp", "examples/**/*.cpp", "bench/**/*.cpp",
                  "fuzz/**/*.cpp", "python/**/*.cpp", "python/**/*.hpp")


def allowed_deps():
    allowed = {}
    for row_index, row in enumerate(STACK):
        below = {m for r in STACK[row_index + 1:] for m in r}
        for module in row:
            allowed[module] = below | {"core"} | ({"io"} if module in IO_USERS else set())
    allowed.update(BESIDE)
    return allowed


def module_files(module):
    for base in (ROOT / "include" / "plumb" / module, ROOT / "src" / module):
        if base.is_dir():
            yield from sorted(p for p in base.rglob("*") if p.suffix in (".hpp", ".cpp", ".h"))


INCLUDE = re.compile(r'^\s*#\s*include\s+"plumb/([a-z0-9_]+)/')


def check_layering(errors):
    allowed = allowed_deps()
    seen = set()
    for module in sorted(allowed):
        for path in module_files(module):
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                m = INCLUDE.match(line)
                if not m or m.group(1) == module:
                    continue
                dep = m.group(1)
                if dep in allowed[module]:
                    continue
                if (module, dep) in KNOWN_EXCEPTIONS:
                    seen.add((module, dep))
                    continue
                rel = path.relative_to(ROOT)
                errors.append(f"{rel}:{number}: {module} includes {dep}, which is not below it "
                              f"(docs/design.md, Layering): {line.strip()}")
    for pair in sorted(set(KNOWN_EXCEPTIONS) - seen):
        errors.append(f"scripts/check_layering.py: the exception {pair[0]} -> {pair[1]} no longer "
                      f"occurs; remove it from KNOWN_EXCEPTIONS and from docs/design.md")


def check_lengths(errors):
    for base in ("include", "src", "examples", "tests", "bench", "fuzz", "python"):
        for path in sorted((ROOT / base).rglob("*")):
            if path.suffix not in (".hpp", ".cpp", ".h") or not path.is_file():
                continue
            rel = str(path.relative_to(ROOT))
            lines = len(path.read_text(encoding="utf-8").splitlines())
            cap = LONG_FILES.get(rel, MAX_LINES)
            if lines > cap:
                what = f"grew past its {cap} lines" if rel in LONG_FILES else f"is over {MAX_LINES} lines"
                errors.append(f"{rel}: {lines} lines; it {what}: split it by concern")
    for rel in LONG_FILES:
        if not (ROOT / rel).is_file():
            errors.append(f"scripts/check_layering.py: {rel} in LONG_FILES no longer exists")


# ---- function lengths -----------------------------------------------------------------------------


def blank_code(text):
    """`text` with comments, preprocessor lines and the contents of string and char literals blanked
    (newlines kept, so line numbers still hold); each literal leaves a bare `""` token behind."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c in " \t":
            out.append(c)
            i += 1
            continue
        if line_start and c == "#":
            # A directive runs to the end of its line, on through backslash continuations; a macro's
            # braces are not a function body.
            while i < n and text[i] != "\n":
                if text.startswith("\\\n", i):
                    out.append(" \n")
                    i += 2
                else:
                    out.append(" ")
                    i += 1
            continue
        line_start = c == "\n"
        if c == "\n":
            out.append(c)
            i += 1
        elif text.startswith("//", i):
            end = text.find("\n", i)
            end = n if end < 0 else end
            out.append(" " * (end - i))
            i = end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append(_blank(text[i:end]))
            i = end
        elif text.startswith('R"', i) and _word_before(text, i) in ("", "u8", "u", "U", "L"):
            m = re.compile(r'R"([^()\\\s]{0,16})\(').match(text, i)
            close = ")" + m.group(1) + '"' if m else '"'
            end = text.find(close, m.end() if m else i + 2)
            end = n if end < 0 else end + len(close)
            out.append('""' + _blank(text[i + 2:end]))
            i = end
        elif c == "'" and _word_before(text, i)[:1].isdigit():
            out.append(" ")  # a digit separator (1'000'000), not a char literal
            i += 1
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append('""' + _blank(text[i + 2:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def _blank(text):
    return re.sub(r"[^\n]", " ", text)


def _word_before(text, i):
    """The number or identifier (with its digit separators) that ends at text[i]."""
    j = i
    while j > 0 and (text[j - 1].isalnum() or text[j - 1] in "_.'"):
        j -= 1
    return text[j:i]


TOKEN = re.compile(r'""|[A-Za-z_]\w*|\d[\w.]*|::|->|\S')


def tokens(code):
    """(token, line) of every token of blanked code."""
    result = []
    for number, line in enumerate(code.split("\n"), 1):
        result.extend((m.group(0), number) for m in TOKEN.finditer(line))
    return result


# What may stand between a function's parameter list and its body, besides `-> type` and `: inits`.
AFTER_PARAMETERS = {"const", "volatile", "noexcept", "override", "final", "mutable", "constexpr", "&", "&&",
                    "throw", "try"}
# A `(` after one of these opens no parameter list.
NOT_A_NAME = {"decltype", "alignas", "__attribute__", "__declspec", "noexcept", "sizeof", "alignof", "throw",
              "static_assert", "if", "for", "while", "switch", "return"}
CLASS_KEYS = {"class", "struct", "union"}


def _closing(words, i, open_, close_):
    """Index of the bracket that closes words[i], or None."""
    depth = 0
    for j in range(i, len(words)):
        depth += (words[j] == open_) - (words[j] == close_)
        if depth == 0:
            return j
    return None


def _ends_signature(tail):
    """Whether the tokens between a parameter list and a `{` belong to a function's signature."""
    i = 0
    while i < len(tail):
        if tail[i] in ("->", ":"):
            return True  # a trailing return type, or a constructor's initializer list
        if tail[i] in ("noexcept", "throw") and i + 1 < len(tail) and tail[i + 1] == "(":
            close = _closing(tail, i + 1, "(", ")")
            if close is None:
                return False
            i = close + 1
        elif tail[i] in AFTER_PARAMETERS:
            i += 1
        else:
            return False
    return True


def function_signature(words):
    """(name, index of the `)` closing the parameter list) when the tokens before a `{` at namespace
    or class scope end a function's signature, else None. The parameter list is the first top-level
    `(...)` followed by nothing but what may end a signature (so `std::function<void(int)> f() {`
    and `operator()(int) {` find theirs)."""
    depth = 0
    for i, word in enumerate(words):
        if word == "(":
            if depth == 0 and i > 0 and words[i - 1] not in NOT_A_NAME:
                close = _closing(words, i, "(", ")")
                if close is not None and _ends_signature(words[close + 1:]):
                    return _function_name(words, i), close
            depth += 1
        elif word == ")":
            depth -= 1
    return None


def _function_name(words, paren):
    """The name before the parameter list at words[paren], with its written qualifiers but without
    template arguments: `KdTree<Dim>::build` -> KdTree::build, `operator<<` as it is."""
    if "operator" in words[:paren]:
        start = max(i for i in range(paren) if words[i] == "operator")
        name = "".join(words[start:paren])
        return "operator " + name[8:] if name[8:9].isalpha() else name
    if words[paren - 1] == "]":
        return "lambda"
    start = paren - 1
    while start > 0:
        if words[start - 1] == "~":
            start -= 1
            continue
        if words[start - 1] != "::" or start < 2:
            break
        j = start - 2
        if words[j] == ">":  # Outer<T>::name
            depth = 0
            while j >= 0:
                depth += (words[j] == ">") - (words[j] == "<")
                if depth == 0:
                    break
                j -= 1
            j -= 1
        if j < 0 or not re.match(r"[A-Za-z_]", words[j]):
            break
        start = j
    name, depth = [], 0
    for word in words[start:paren]:
        depth += word == "<"
        if depth == 0:
            name.append(word)
        depth -= word == ">" and depth > 0
    return "".join(name)


def _class_name(words):
    """The (qualified) name a class head declares: `struct alignas(64) Node` -> Node,
    `class Outer::Inner final : Base` -> Outer::Inner; "" for an anonymous one."""
    rest = words[max(k for k, w in enumerate(words) if w in CLASS_KEYS) + 1:]
    if rest[:2] == ["alignas", "("]:
        close = _closing(rest, 1, "(", ")")
        rest = rest[close + 1:] if close is not None else []
    name = []
    for word in rest:
        if not (word == "::" or (re.match(r"[A-Za-z_]\w*$", word) and (not name or name[-1] == "::"))):
            break
        name.append(word)
    return "".join(name)


def _without_template_header(words):
    """The declaration without its `template <...>` headers (whose `class T = X` are no class)."""
    while words[:2] == ["template", "<"]:
        close = _closing(words, 1, "<", ">")
        words = words[close + 1:] if close is not None else []
    return words


def functions(text):
    """(name, first line, last line) of every function body at namespace or class scope of a C++
    source, and a message when its braces do not balance (else None). The name is qualified by the
    classes the definition sits in; the first line is that of the declaration's first token."""
    toks = tokens(blank_code(text))
    found = []
    scopes = []  # class name ("" for a namespace or extern "C" body) of each open scope
    decl = []  # (token, line) of the declaration read so far
    i = 0
    while i < len(toks):
        tok, line = toks[i]
        if tok == "{":
            words = [t for t, _ in decl]
            signature = function_signature(words)
            in_inits = signature is not None and ":" in words[signature[1] + 1:]
            if signature is not None and not (in_inits and words[-1] not in (")", "{}")):
                close = _closing([t for t, _ in toks], i, "{", "}")
                if close is None:
                    return found, f"line {line}: the function's braces do not close"
                name = signature[0]
                if "::" not in name:
                    name = "::".join([s for s in scopes if s] + [name])
                found.append((name, decl[0][1], toks[close][1]))
                decl = []
                i = close + 1
                continue
            head = _without_template_header(words)
            if signature is not None or not ("namespace" in words or words[:1] == ["extern"]
                                             or (CLASS_KEYS & set(head) and "=" not in head)):
                # A member's brace initializer in a constructor's initializer list, an enum's body, a
                # brace initializer or a default argument `= {}`: skipped whole, part of the declaration.
                close = _closing([t for t, _ in toks], i, "{", "}")
                if close is None:
                    return found, f"line {line}: braces do not close"
                decl.append(("{}", line))
                i = close + 1
                continue
            if "namespace" in words or words[:1] == ["extern"]:
                scopes.append("")
            else:
                scopes.append(_class_name(head))
            decl = []
        elif tok == "}":
            if not scopes:
                return found, f"line {line}: a `}}` closes nothing"
            scopes.pop()
            decl = []
        elif tok == ";" or (tok == ":" and decl and decl[-1][0] in ("public", "private", "protected")):
            decl = []
        else:
            decl.append((tok, line))
        i += 1
    return found, "braces left open at the end of the file" if scopes else None


def check_function_lengths(errors):
    longest = {}
    for pattern in FUNCTION_GLOBS:
        for path in sorted(ROOT.glob(pattern)):
            rel = str(path.relative_to(ROOT))
            found, problem = functions(path.read_text(encoding="utf-8"))
            if problem:
                errors.append(f"{rel}: {problem}; scripts/check_layering.py cannot measure its functions")
            for name, first, last in found:
                key = f"{rel}:{name}"
                length = last - first + 1
                longest[key] = max(longest.get(key, 0), length)
                cap = LONG_FUNCTIONS.get(key, MAX_FUNCTION_LINES)
                if length > cap:
                    what = (f"grew past its {cap} lines" if key in LONG_FUNCTIONS
                            else f"is over {MAX_FUNCTION_LINES} lines")
                    errors.append(f"{rel}:{first}: {name} has {length} lines; it {what}: split it into named stages")
    for key in LONG_FUNCTIONS:
        if longest.get(key, 0) <= MAX_FUNCTION_LINES:
            errors.append(f"scripts/check_layering.py: {key} in LONG_FUNCTIONS is no longer over "
                          f"{MAX_FUNCTION_LINES} lines (or no longer exists); remove it")


def main():
    errors = []
    check_layering(errors)
    check_lengths(errors)
    check_function_lengths(errors)
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"check_layering: {len(errors)} breach(es)", file=sys.stderr)
        return 1
    print("check_layering: layering, file and function lengths as in docs/design.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
