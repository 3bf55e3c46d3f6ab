#!/usr/bin/env python3
"""Writes one JUnit test case to a file, for results that no test framework
writes itself (a sanitizer report, a crashed test binary, the fuzzer), so that
summarize_results.py counts them.

  junit_case.py OUT.xml SUITE NAME [--failure MESSAGE | --skipped MESSAGE]
                [--details FILE]... [--output TEXT]

--details: files whose text goes into the failure (reports, log tails; each
cut to its last 20000 characters); --output: text for <system-out>."""
import argparse
import pathlib
import xml.etree.ElementTree as ET

MAX_DETAIL_CHARS = 20000

parser = argparse.ArgumentParser()
parser.add_argument("out")
parser.add_argument("suite")
parser.add_argument("name")
verdict = parser.add_mutually_exclusive_group()
verdict.add_argument("--failure")
verdict.add_argument("--skipped")
parser.add_argument("--details", action="append", default=[])
parser.add_argument("--output", default="")
args = parser.parse_args()

details = []
for name in args.details:
    path = pathlib.Path(name)
    text = path.read_text(errors="replace") if path.is_file() else "(missing)\n"
    if len(text) > MAX_DETAIL_CHARS:
        text = "...\n" + text[-MAX_DETAIL_CHARS:]
    details.append(f"==> {name} <==\n{text}")

suite = ET.Element("testsuite", name=args.suite, tests="1",
                   failures="1" if args.failure else "0",
                   skipped="1" if args.skipped else "0")
case = ET.SubElement(suite, "testcase", classname=args.suite, name=args.name)
if args.failure:
    ET.SubElement(case, "failure", message=args.failure).text = "\n".join(details)
elif args.skipped:
    ET.SubElement(case, "skipped", message=args.skipped)
if args.output:
    ET.SubElement(case, "system-out").text = args.output
pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
ET.ElementTree(suite).write(args.out, encoding="utf-8", xml_declaration=True)
