#!/usr/bin/env python3
"""Lists the functions of src/hisfm (tests left out) longer than a limit.

Usage: scripts/long_functions.py [--limit N] [--count] [PATH ...]

A function's length is its number of lines, from the first line of its
signature to its closing brace. The C++ is read with a small scanner
(comments, strings and character literals skipped; namespace, class,
struct and union bodies looked into), good enough for the project's
formatting: no dependency beyond Python's standard library. Prints
"LINES FILE:LINE NAME" longest first, then the count; --count prints only
the count.
"""
import argparse
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Bodies that hold declarations rather than statements.
SCOPE_RE = re.compile(r'\b(namespace|class|struct|union)\b[^()]*$')
NOT_FUNCTION_RE = re.compile(r'(\benum\b|=\s*$|\bextern\s+"C"\s*$)')


def strip_code(text):
    """Blanks comments, strings and character literals, keeping newlines."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            i = j
        elif text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(')' + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append('""' + re.sub(r'[^\n]', ' ', text[i + 2:j]))
            i = j
        elif c in '"\'':
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == '\\' else 1
            out.append(c + ' ' * (j - i - 1) + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return ''.join(out)


def functions(path):
    """Yields (name, first line, number of lines) of each function body."""
    code = strip_code(open(path, encoding='utf-8').read())
    # Each open brace: 'scope' (namespace, class...), 'function' or 'block'.
    stack = []
    head_start = 0  # where the text before the next brace begins
    func_start = None
    for i, c in enumerate(code):
        if c == '{':
            head = code[head_start:i]
            in_function = any(kind == 'function' for kind, _, _ in stack)
            if in_function:
                stack.append(('block', None, None))
            elif SCOPE_RE.search(' '.join(head.split())):
                stack.append(('scope', None, None))
            elif '(' in head and not NOT_FUNCTION_RE.search(head.strip()):
                stripped = head.lstrip()
                start = i - len(head) + (len(head) - len(stripped))
                name_match = re.search(r'([~\w:<>=!+\-*/\[\]]+)\s*\(', head)
                name = name_match.group(1) if name_match else '?'
                stack.append(('function', name, start))
            else:
                stack.append(('block', None, None))
            head_start = i + 1
        elif c == '}':
            if stack:
                kind, name, start = stack.pop()
                if kind == 'function':
                    first = code.count('\n', 0, start) + 1
                    last = code.count('\n', 0, i) + 1
                    yield name, first, last - first + 1
            head_start = i + 1
        elif c == ';' and not any(k == 'function' for k, _, _ in stack):
            head_start = i + 1


def source_files(paths):
    for base in paths:
        if os.path.isfile(base):
            yield base
            continue
        for folder, _, names in sorted(os.walk(base)):
            for name in sorted(names):
                if name.endswith('.cc') and not name.endswith('_test.cc') \
                        and not name.endswith('test_util.cc'):
                    yield os.path.join(folder, name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--limit', type=int, default=80,
                        help='list functions longer than this many lines')
    parser.add_argument('--count', action='store_true',
                        help='print only the number of long functions')
    parser.add_argument('paths', nargs='*',
                        default=[os.path.join(ROOT, 'src', 'hisfm')])
    args = parser.parse_args()
    long = []
    for path in source_files(args.paths):
        for name, line, length in functions(path):
            if length > args.limit:
                long.append((length, os.path.relpath(path, ROOT), line, name))
    long.sort(key=lambda f: (-f[0], f[1], f[2]))
    if not args.count:
        for length, path, line, name in long:
            print(f'{length:5d} {path}:{line} {name}')
    print(len(long))
    return 0


if __name__ == '__main__':
    sys.exit(main())
