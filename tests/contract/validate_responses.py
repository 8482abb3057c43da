#!/usr/bin/env python3
"""Checks real HTTP responses against the API contract, docs/openapi.yaml.

usage: validate_responses.py SPEC RESPONSES.jsonl

Each line of RESPONSES is one response a test received: {"method", "path" (without the query),
"status", "content_type", "body"}. A response conforms when its path and method are in the spec
(or it is a 405 for a path that is, or a 404 for one that is not), its status is declared for
that operation, and its body matches the declared content: JSON validated against the declared
schema (OpenAPI 3.0: `nullable` is read as JSON Schema's null type), other media by their
type, and no body where none is declared. Prints every problem and exits 1 if there is one.
"""
import json
import re
import sys

import jsonschema
import yaml


def to_json_schema(node):
    """OpenAPI 3.0 schema objects as JSON Schema (draft 7): nullable becomes a null type."""
    if isinstance(node, list):
        return [to_json_schema(n) for n in node]
    if not isinstance(node, dict):
        return node
    out = {k: to_json_schema(v) for k, v in node.items() if k != "nullable"}
    if node.get("nullable") and "type" in out:
        out["type"] = [out["type"], "null"]
    return out


def path_pattern(template):
    return re.compile("^" + re.sub(r"\{[^}]+\}", "[^/]+", re.escape(template).replace(r"\{", "{").replace(r"\}", "}")) + "$")


def main():
    spec = yaml.safe_load(open(sys.argv[1]))
    root = to_json_schema(spec)
    resolver = jsonschema.RefResolver.from_schema(root)
    patterns = [(path_pattern(p), p) for p in spec["paths"]]
    error_schema = {"$ref": "#/components/schemas/Error"}

    def check_json(schema, body, where, problems):
        try:
            document = json.loads(body)
        except ValueError as e:
            problems.append(f"{where}: the body is not JSON ({e})")
            return
        validator = jsonschema.Draft7Validator(to_json_schema(schema), resolver=resolver)
        for error in validator.iter_errors(document):
            location = "/".join(str(p) for p in error.absolute_path)
            problems.append(f"{where}: /{location}: {error.message[:300]}")

    def resolve(response):
        while "$ref" in response:
            name = response["$ref"].split("/")[-1]
            response = spec["components"]["responses"][name]
        return response

    problems = []
    count = 0
    for line in open(sys.argv[2]):
        if not line.strip():
            continue
        count += 1
        r = json.loads(line)
        method, path, status = r["method"].lower(), r["path"], str(r["status"])
        where = f"{r['method']} {path} -> {status}"
        template = next((t for pattern, t in patterns if pattern.match(path)), None)
        if template is None:
            if status == "404":
                check_json(error_schema, r["body"], where, problems)
            else:
                problems.append(f"{where}: the path is not in the spec")
            continue
        operation = spec["paths"][template].get(method)
        if operation is None:
            if status == "405":
                check_json(error_schema, r["body"], where, problems)
            else:
                problems.append(f"{where}: {r['method']} is not in the spec for {template}")
            continue
        declared = operation["responses"].get(status) or operation["responses"].get("default")
        if declared is None:
            problems.append(f"{where}: status {status} is not declared for "
                            f"{operation.get('operationId', template)}")
            continue
        declared = resolve(declared)
        content = declared.get("content")
        if not content:
            if r["body"]:
                problems.append(f"{where}: a body where the spec declares none")
            continue
        media = r["content_type"].split(";")[0].strip()
        if media not in content:
            problems.append(f"{where}: content type {media}, the spec declares {list(content)}")
            continue
        schema = content[media].get("schema") if content[media] else None
        if media == "application/json" and schema is not None:
            check_json(schema, r["body"], where, problems)
    for p in problems:
        print(p)
    print(f"{count} responses, {len(problems)} problems")
    return 1 if problems or count == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
