"""The options classes are generated from the C++ option schema (VisitFields): every schema
field is an attribute with its doc and the C++ default, range and type checks apply."""
import copy
import os

import pytest

import aerovo

CLASSES = [aerovo.SurfOptions, aerovo.MatchOptions, aerovo.RansacOptions,
           aerovo.ClusteredRansacOptions, aerovo.CorrespondenceOptions, aerovo.OdometryOptions]


def leaves(obj, prefix=""):
    """(key, value, owner class, attribute) of every field below obj, keyed as the schema keys
    them: a group's fields are "group.field", the innermost group's name only
    (core/options.h)."""
    for name, value in obj.to_dict().items():
        child = getattr(obj, name)
        if hasattr(child, "to_dict"):
            yield from leaves(child, name + ".")
        else:
            yield prefix + name, child, type(obj), name


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_schema_field_is_an_attribute_with_its_default(cls):
    fields = cls.fields()
    assert len(fields) >= 5
    extras = {"roi", "focal_px", "default_height_m"}  # bound by hand: not in the schema
    found = [leaf for leaf in leaves(cls()) if leaf[3] not in extras]
    assert [leaf[0] for leaf in found] == [f["key"] for f in fields]
    for f, (key, value, owner, name) in zip(fields, found):
        if isinstance(value, bool):
            assert f["default"] == ("true" if value else "false"), key
        elif isinstance(value, str):
            assert f["type"].count("|") >= 1 and value in f["type"].split(" | "), key
            assert f["default"] == value
        else:
            assert float(f["default"]) == pytest.approx(value, rel=1e-6), key
        # The doc of the property is the schema's.
        assert getattr(owner, name).__doc__.startswith(f["doc"]), key


def test_nested_groups_and_the_odometry_defaults():
    c = aerovo.CorrespondenceOptions()
    assert c.method == "clustered" and c.model == "affine"
    c.ransac.seed = 7  # a live view: changes c
    assert c.ransac.seed == 7 and c.to_dict()["ransac"]["seed"] == 7
    c.clustered = {"grid_rows": 4}
    assert c.clustered.grid_rows == 4 and c.clustered.grid_cols == 3
    o = aerovo.OdometryOptions(focal_px=800.0, default_height_m=50)
    # OdometryOptions' own defaults for its stages (odometry/visual_odometry.h).
    assert o.surf.adaptive is True and o.surf.num_threads == 0
    assert o.correspondence.min_inliers == 12 and o.correspondence.guided_matching is True
    assert o.focal_px == 800.0 and o.default_height_m == 50.0
    assert copy.deepcopy(o) == o and o != aerovo.OdometryOptions()
    assert "surf" in repr(o) and "hessian_threshold=1000.0" in repr(aerovo.SurfOptions())


def test_the_run_options_are_the_same_schema():
    # docs/options.md is `aerovo run --list-options` (an e2e test keeps it current); the
    # odometry's own fields are odometry.* there.
    source = os.environ.get("AEROVO_SOURCE_DIR")
    if not source:
        pytest.skip("AEROVO_SOURCE_DIR (the source tree) is not set: run through ctest")
    with open(os.path.join(source, "docs", "options.md")) as f:
        listed = f.read()
    fields = aerovo.OdometryOptions.fields()
    assert len(fields) > 50
    for f in fields:
        assert f"`{f['key']}`" in listed or f"`odometry.{f['key']}`" in listed, f["key"]


def test_type_and_range_errors():
    o = aerovo.SurfOptions()
    with pytest.raises(ValueError, match="SurfOptions.hessian_threshold must be finite and >= 0, got -1"):
        o.hessian_threshold = -1
    with pytest.raises(ValueError, match=r"num_scale_levels must be in \[3, 16\], got 2"):
        o.num_scale_levels = 2
    with pytest.raises(TypeError, match="num_octaves must be an int, got float"):
        o.num_octaves = 3.5
    with pytest.raises(TypeError, match="upright must be a bool, got int"):
        o.upright = 1
    with pytest.raises(TypeError, match="has no option 'treshold'.*hessian_threshold"):
        aerovo.SurfOptions(treshold=3)
    with pytest.raises(ValueError, match="method must be one of standard | clustered, got 'best'"):
        aerovo.CorrespondenceOptions(method="best")
    with pytest.raises(ValueError, match="must be in"):
        aerovo.RansacOptions().seed = -1
    o.hessian_threshold = 250  # an int for a float field
    assert o.hessian_threshold == 250.0
    assert o.roi is None
    o.roi = (10, 20, 100, 50)
    assert o.roi == (10, 20, 100, 50)
    with pytest.raises(ValueError, match="roi"):
        o.roi = (0, 0, 0, 5)
    with pytest.raises(TypeError, match="options must be an aerovo.SurfOptions"):
        aerovo.Surf(options=aerovo.RansacOptions())
