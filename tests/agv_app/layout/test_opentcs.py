"""openTCS plant-model import: Demo-01, the V7 sample, and clear errors for bad files."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

from agv_app.layout import (
    LayoutFileError,
    import_notes,
    load_opentcs,
    parse_plant_model,
    plant_model_to_layout,
    read_plant_model,
)
from agv_app.layout.json_format import load_any

DATA = Path(str(resources.files("agv_app").joinpath("data", "opentcs")))
DEMO = DATA / "Demo-01.xml"
SAMPLE = DATA / "PlantModelV7.sample.xml"


def test_demo01_is_shipped_with_its_licence() -> None:
    assert "CC-BY-4.0" in (DATA / "LICENSE.txt").read_text()


def test_demo01_model_counts() -> None:
    model = read_plant_model(DEMO)
    assert (len(model.points), len(model.paths), len(model.locations)) == (59, 75, 16)
    assert model.version == "7.0.0"
    assert model.vehicle_size_mm == (1000.0, 1000.0)
    assert (model.scale_x_mm, model.scale_y_mm) == (50.0, 50.0)


def test_demo01_layout() -> None:
    layout = load_opentcs(DEMO)
    assert layout.name == "Demo-01"
    assert len(layout.points) == 59
    # Demo-01 has no opposite path pairs: every path is its own one-way segment.
    assert len(layout.segments) == 75
    assert not any(s.bidirectional for s in layout.segments.values())
    assert layout.point("Point-0001").xy == (31.0, 11.0)  # mm -> m
    # 15 linked locations (the fire door links nowhere) + 5 park positions.
    assert len(layout.stations) == 20
    assert layout.station("Recharge 01").kind == "charging"
    assert layout.station("Goods in north 01").kind == "pickdrop"
    assert layout.station("Point-0027").kind == "parking"
    assert layout.unreachable_stations() == ()
    assert len(layout.usable_stations()) == 20
    assert layout.blocks["Block-0004"] == frozenset(
        {"Point-0015 --- Point-0050", "Point-0045 --- Point-0016", "Point-0045 --- Point-0055"}
    )
    for a in layout.usable_stations()[:5]:
        for b in layout.usable_stations():
            layout.route(layout.station(a).point, layout.station(b).point)


def test_demo01_bezier_paths_are_curved() -> None:
    layout = load_opentcs(DEMO)
    seg = layout.segment("Point-0001 --- Point-0002")
    assert len(seg.via) == 7
    # The curve bends through the control point (610, -180) * 50 mm = (30.5, 9.0) m.
    assert min(abs(x - 30.5) + abs(y - 9.0) for x, y in seg.via) < 1.0
    x0, y0, x1, y1 = layout.bounds()
    assert (x0, y0, x1, y1) == pytest.approx((-24.0, -21.0, 31.0, 15.0), abs=0.5)


def test_demo01_notes() -> None:
    notes = import_notes(read_plant_model(DEMO))
    assert notes == ("location 'Fire door 01' links to no point: left out",)


def test_sample_model_edge_cases() -> None:
    model = read_plant_model(SAMPLE)
    layout = plant_model_to_layout(model)
    assert "Point-0013 --- Point-0014" not in layout.segments  # locked
    assert layout.segment("Point-0007 --- Point-0008").via == ((23.0, 6.0), (24.5, 7.5))
    assert len(layout.segment("Point-0011 --- Point-0012").via) > 10  # BEZIER_3
    assert layout.blocks["Block-0001"] == frozenset({"Location-0001", "Point-0013"})
    assert layout.blocks["Block-0002"] == frozenset()
    notes = import_notes(model)
    assert any("locked" in n for n in notes)
    assert any("'Point-0015'" in n and "usable_stations" in n for n in notes)
    assert "Point-0015" in layout.unreachable_stations()


def model(body: str, *, version: str = "7.0.0") -> str:
    return f'<?xml version="1.0"?>\n<model version="{version}" name="t">\n{body}\n</model>\n'


PTS = """
<point name="A" positionX="0" positionY="0" type="HALT_POSITION"/>
<point name="B" positionX="5000" positionY="0" type="PARK_POSITION"/>
"""


def test_opposite_paths_become_one_bidirectional_segment() -> None:
    xml = model(
        PTS
        + '<path name="A --- B" sourcePoint="A" destinationPoint="B"/>'
        + '<path name="B --- A" sourcePoint="B" destinationPoint="A"/>'
        + '<locationType name="Charger"><allowedOperation name="CHARGE"/></locationType>'
        + '<locationType name="In"><allowedOperation name="Load cargo"/></locationType>'
        + '<locationType name="Out"><allowedOperation name="Unload"/></locationType>'
        + '<location name="C" type="Charger"><link point="A"/></location>'
        + '<location name="I" type="In"><link point="A"/><link point="B"/></location>'
        + '<location name="O" type="Out"><link point="B"/></location>'
        + '<block name="K"><member name="B --- A"/><member name="I"/></block>'
    )
    layout = plant_model_to_layout(parse_plant_model(xml))
    assert list(layout.segments) == ["A --- B"]
    assert layout.segment("A --- B").bidirectional
    assert layout.segment_length("A --- B") == 5.0
    kinds = {s.id: s.kind for s in layout.stations.values()}
    assert kinds == {"C": "charging", "I@A": "pick", "I@B": "pick", "O": "drop", "B": "parking"}
    assert layout.blocks["K"] == frozenset({"A --- B", "I@A", "I@B"})


def test_reverse_velocity_makes_a_path_bidirectional() -> None:
    xml = model(
        PTS + '<path name="p" sourcePoint="A" destinationPoint="B" maxReverseVelocity="5"/>'
    )
    assert plant_model_to_layout(parse_plant_model(xml)).segment("p").bidirectional


@pytest.mark.parametrize(
    ("xml", "message", "where"),
    [
        ("<model version='7.0'><point name='A'", "not well-formed XML", "line 1"),
        ("<?xml version='1.0'?>\n<svg/>", "root element is <svg>, expected <model>", "line 2"),
        (model("", version="5.0"), "unsupported plant model version '5.0'", "line 2"),
        (
            model('<point name="A" positionY="0"/>'),
            "<point name='A'> lacks attribute 'positionX'",
            "line 3",
        ),
        (
            model('<point name="A" positionX="abc" positionY="0"/>'),
            "<point name='A'> attribute positionX='abc' is not a finite number",
            "line 3",
        ),
        (
            model(PTS + '<path name="p" destinationPoint="B"/>'),
            "<path name='p'> lacks attribute 'sourcePoint'",
            "line 6",
        ),
        (
            '<?xml version="1.0"?>\n<!DOCTYPE model [<!ENTITY x "y">]>\n<model version="7"/>',
            "DTDs and entities are not allowed",
            "line 2",
        ),
    ],
)
def test_parse_errors_name_the_element_and_line(xml: str, message: str, where: str) -> None:
    with pytest.raises(LayoutFileError, match=message) as exc:
        parse_plant_model(xml, source="bad.xml")
    assert exc.value.where == where
    assert str(exc.value).startswith(f"{where}: bad.xml: ")


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            PTS + '<path name="p" sourcePoint="A" destinationPoint="Z"/>',
            "<path name='p'> refers to unknown point 'Z'",
        ),
        (
            PTS + '<location name="L" type="T"><link point="Q"/></location>',
            "<location name='L'> links to unknown point 'Q'",
        ),
        (PTS + '<point name="A" positionX="1" positionY="1"/>', "duplicate point 'A'"),
        (
            PTS.replace('positionX="5000"', 'positionX="0"')
            + '<path name="p" sourcePoint="A" destinationPoint="B"/>',
            "segment 'p': zero length",
        ),
    ],
)
def test_conversion_errors(body: str, message: str) -> None:
    with pytest.raises(LayoutFileError, match=message):
        plant_model_to_layout(parse_plant_model(model(body)))


def test_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(LayoutFileError, match="cannot read plant model"):
        load_opentcs(tmp_path / "missing.xml")


def test_load_any_dispatches_on_suffix(tmp_path: Path) -> None:
    assert load_any(DEMO).name == "Demo-01"
    assert load_any("demo").name == "demo-warehouse"
    with pytest.raises(LayoutFileError, match=r"expected a \.json or \.xml file"):
        load_any(tmp_path / "plan.yaml")
