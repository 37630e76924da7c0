#!/usr/bin/env python3
"""Validates MaterialX documents with the MaterialX library's own validator.

Each FILE.mtlx is read, the standard data libraries (which define `open_pbr_surface` and
`surfacematerial`) are imported, and `Document.validate()` is run; the validator's messages are
printed. Exit codes: 0 every document is valid, 1 a document is invalid, 2 usage, 3 the MaterialX
Python bindings are not installed (install them with `pip install materialx==1.39.5`).

    usage: python3 scripts/gltf/validate_mtlx.py FILE.mtlx ...
"""

import sys


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip().splitlines()[-1].strip(), file=sys.stderr)
        return 2
    try:
        import MaterialX as mx
    except ImportError:
        print(
            "validate_mtlx.py: the MaterialX Python bindings are not installed "
            "(pip install materialx==1.39.5); MaterialX validation did not run",
            file=sys.stderr,
        )
        return 3
    stdlib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), stdlib)
    failed = False
    for path in argv[1:]:
        doc = mx.createDocument()
        try:
            mx.readFromXmlFile(doc, path)
        except mx.ExceptionParseError as e:
            print(f"{path}: not well-formed MaterialX: {e}")
            failed = True
            continue
        doc.setDataLibrary(stdlib)
        valid, message = doc.validate()
        nodes = [n.getCategory() for n in doc.getNodes()]
        missing = [
            n.getName()
            for n in doc.getNodes()
            if n.getNodeDef() is None
        ]
        if missing:
            valid = False
            message += f"nodes without a nodedef in MaterialX {mx.getVersionString()}: {missing}\n"
        print(
            f"{path}: {'valid' if valid else 'INVALID'} (MaterialX {mx.getVersionString()}, nodes {nodes})"
        )
        if message:
            print("  " + message.strip().replace("\n", "\n  "))
        failed |= not valid
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
