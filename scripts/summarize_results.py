#!/usr/bin/env python3
"""Counts passed/failed/skipped test cases over JUnit XML files (gtest, rostest)
and prints the closing line 'N passed, N failed, N skipped'. Exit 1 on failures
or when nothing ran."""
import pathlib
import sys
import xml.etree.ElementTree as ET

root = pathlib.Path(sys.argv[1])
passed = failed = skipped = 0
failures = []
for path in sorted(root.rglob("*.xml")):
    try:
        tree = ET.parse(path)
    except ET.ParseError as exc:
        failed += 1
        failures.append(f"{path.name}: unreadable result file ({exc})")
        continue
    for case in tree.iter("testcase"):
        name = f"{case.get('classname')}.{case.get('name')}"
        if case.find("failure") is not None or case.find("error") is not None:
            failed += 1
            failures.append(f"{name} ({path.relative_to(root)})")  # the path tells the suite (asan/, fuzz/)
        elif case.find("skipped") is not None or case.get("status") == "notrun" or case.get("result") == "skipped":
            skipped += 1
        else:
            passed += 1
for f in failures:
    print(f"FAILED: {f}")
print(f"{passed} passed, {failed} failed, {skipped} skipped")
sys.exit(1 if failed or passed == 0 else 0)
