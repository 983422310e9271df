"""Every field of the options structs of lib/ is an attribute of its Python class: a field
added to a struct needs one G6D_FIELD line in tools/python/types.cc, and this test names
the line that is missing. (A field removed from a struct fails the
module's compilation instead.)"""

import re

import pytest

import g6d
from conftest import SOURCE_DIR

# Struct -> header. A nested options struct is checked by its own entry.
STRUCTS = {
    "SolverOptions": "lib/solver/solver_options.h",
    "TrackSolveOptions": "lib/solver/track_pose.h",
    "DetectOptions": "lib/solver/detect_options.h",
    "IdentifyOptions": "lib/solver/identify.h",
    "OrbOptions": "lib/templates/features.h",
    "RegionOptions": "lib/solver/region.h",
    "SegmentOptions": "lib/solver/segments.h",
    "MatchOptions": "lib/solver/match.h",
    "PnpOptions": "lib/solver/pnp.h",
    "ScoreOptions": "lib/solver/score.h",
    "GridOptions": "lib/solver/observation.h",
    "IcpOptions": "lib/solver/icp.h",
    "MhpoOptions": "lib/solver/mhpo.h",
    "AppearanceOptions": "lib/templates/appearance.h",
    "TemplateBuildOptions": "lib/templates/template_bank.h",
    "ViewSamplingOptions": "lib/templates/views.h",
    "CropOptions": "lib/templates/crop.h",
    "SymmetryOptions": "lib/mesh/symmetry.h",
    "PpfSearchOptions": "lib/solver/ppf.h",
    "SilhouetteOptions": "lib/solver/silhouette_poses.h",
    "PpfModelOptions": "lib/templates/ppf_model.h",
    "ConfidenceWeights": "lib/solver/solver_options.h",
}
# Fields a Python caller cannot use, and why.
NOT_BOUND = {
    ("SolverOptions", "stop_requested"),  # a pointer to the caller's atomic flag; use budget_ms
}
# A data member at the struct's indentation: `type name = ...;`, `type name;`, `type name = [] {`.
FIELD = re.compile(r"^  (?:const )?[A-Za-z_][\w:<>, ]*?\*? ([a-z_][a-z0-9_]*)(?: = .*|;|\{.*)$")


def header_fields(struct, header):
    text = (SOURCE_DIR / header).read_text()
    match = re.search(rf"^struct {struct} \{{\n(.*?)^\}};", text, re.S | re.M)
    assert match, f"struct {struct} not found in {header}"
    fields = []
    for line in match.group(1).splitlines():
        code = line.split("//")[0]
        if not code.strip() or "(" in code.split("=")[0]:
            continue  # comments, member functions
        found = FIELD.match(code.rstrip())
        if found:
            fields.append(found.group(1))
    return fields


@pytest.mark.parametrize("struct", sorted(STRUCTS))
def test_every_field_is_bound(struct):
    expected = [f for f in header_fields(struct, STRUCTS[struct]) if (struct, f) not in NOT_BOUND]
    bound = list(getattr(g6d, struct)._fields) if hasattr(g6d, struct) else list(getattr(g6d._core, struct)._fields)
    missing = [f for f in expected if f not in bound]
    assert not missing, (f"{struct} ({STRUCTS[struct]}) has fields the Python module does not bind: {missing}; "
                         f"add G6D_FIELD({missing[0]}) to its list in tools/python/types.cc")


def test_stub_lists_every_field():
    """The .pyi stub declares each options class with the fields the module binds."""
    import ast
    stub = ast.parse((SOURCE_DIR / "tools" / "python" / "g6d" / "__init__.pyi").read_text())
    classes = {node.name: node for node in stub.body if isinstance(node, ast.ClassDef)}
    for struct in STRUCTS:
        assert struct in classes, f"g6d/__init__.pyi has no class {struct}"
        declared = [n.target.id for n in classes[struct].body if isinstance(n, ast.AnnAssign)]
        assert declared == list(getattr(g6d, struct)._fields), f"g6d/__init__.pyi: {struct}"
