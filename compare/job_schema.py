"""job.json's schema, as the comparison scripts read it (docs/compare.md, "The job").

`airmass compare` writes "format" and "schema_version" into DIR/job.json; both come from
plan.json beside this file (the comparison's one table of paths and its job schema, built into
the CLI: airmass/compare_plan.hpp), so the CLI and these scripts cannot disagree unless they
come from different builds. blender_render.py and report.py load a job through `load`, which
refuses a job of another format or version with an error naming the field, instead of failing
later on a missing key. tests/python/test_compare_plan.py checks that the CLI's
`airmass compare --list-paths --json` ("job_schema_version") equals SCHEMA_VERSION here.
"""

import json
import os

PLAN_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "plan.json")


class JobSchemaError(ValueError):
    """The job is not one these scripts read; the message names the field."""


def _plan_schema():
    """(job_format, job_schema_version) of plan.json beside this file; JobSchemaError naming the
    file and the field when it is missing or malformed (the scripts came without it)."""
    try:
        with open(PLAN_FILE, encoding="utf-8") as f:
            plan = json.load(f)
        fmt, version = plan["job_format"], plan["job_schema_version"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise JobSchemaError("%s: the comparison's plan is missing or unreadable (%s: %s); run the scripts from "
                             "the folder the airmass CLI came with" % (PLAN_FILE, type(e).__name__, e)) from None
    if not isinstance(fmt, str) or not isinstance(version, int):
        raise JobSchemaError("%s: field \"job_format\" must be a string and \"job_schema_version\" an integer"
                             % PLAN_FILE)
    return fmt, version


FORMAT, SCHEMA_VERSION = _plan_schema()


def check(job, where="job.json"):
    """Raises JobSchemaError unless `job` is a job of FORMAT and SCHEMA_VERSION."""
    if not isinstance(job, dict):
        raise JobSchemaError("%s: not a JSON object" % where)
    if job.get("format") != FORMAT:
        raise JobSchemaError("%s: field \"format\" is %r, not %r (not a job of `airmass compare`)"
                             % (where, job.get("format"), FORMAT))
    version = job.get("schema_version")
    if version != SCHEMA_VERSION:
        raise JobSchemaError("%s: field \"schema_version\" is %r; these scripts read schema_version %d (run them "
                             "with the airmass CLI they came with)" % (where, version, SCHEMA_VERSION))
    return job


def load(path):
    """The job at `path`, checked."""
    with open(path, encoding="utf-8") as f:
        try:
            job = json.load(f)
        except ValueError as e:
            raise JobSchemaError("%s: not JSON (%s)" % (path, e)) from None
    return check(job, path)
