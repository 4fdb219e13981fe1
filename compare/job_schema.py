"""job.json's schema, as the comparison scripts read it (docs/compare.md, "The job").

`airmass compare` (plugin/cli/compare_plan.hpp: kJobFormat, kJobSchemaVersion) writes
"format" and "schema_version" into DIR/job.json; blender_render.py and report.py load it
through `load`, which refuses a job of another format or version with an error naming the
field, instead of failing later on a missing key. The CLI prints the version it writes with
`airmass compare --list-paths --json` ("job_schema_version"); tests/python/test_compare_plan.py
checks that it equals SCHEMA_VERSION here.
"""

import json

FORMAT = "airmass-compare-job"
SCHEMA_VERSION = 2


class JobSchemaError(ValueError):
    """The job is not one these scripts read; the message names the field."""


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
