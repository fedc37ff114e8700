"""Small OpenDRIVE files written by hand for the reader's tests."""

from __future__ import annotations

from pathlib import Path

LANES_TWO_RIGHT = """
        <lanes>
            <laneOffset s="0" a="{offset}" b="0" c="0" d="0"/>
            <laneSection s="0">
                <center><lane id="0" type="none"/></center>
                <right>
                    <lane id="-1" type="driving">{link1}
                        <width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
                    <lane id="-2" type="driving">{link2}
                        <width sOffset="0" a="3.0" b="0.01" c="0" d="0"/></lane>
                </right>
            </laneSection>
        </lanes>"""


def road_xml(road_id: str, length: float, geometry: str, links: str = "",
             lane_links: bool = False, offset: float = 0.0, extra: str = "") -> str:
    """One road with two right driving lanes (-1: 3.5 m, -2: widening from 3.0 m)."""
    link1 = link2 = ""
    if lane_links:
        link1 = '<link><predecessor id="-1"/><successor id="-1"/></link>'
        link2 = '<link><predecessor id="-2"/><successor id="-2"/></link>'
    lanes = LANES_TWO_RIGHT.format(offset=offset, link1=link1, link2=link2)
    return f"""
    <road id="{road_id}" junction="-1" length="{length}">
        <link>{links}</link>
        <type s="0" type="town"><speed max="50" unit="km/h"/></type>
        <planView>{geometry}</planView>
        <elevationProfile><elevation s="0" a="1.0" b="0.01" c="0" d="0"/></elevationProfile>
        {lanes}{extra}
    </road>"""


def opendrive(*roads: str) -> str:
    """A whole OpenDRIVE document around some roads."""
    return ('<?xml version="1.0"?>\n<OpenDRIVE>\n    <header revMajor="1" revMinor="4"/>'
            + "".join(roads) + "\n</OpenDRIVE>\n")


def write(tmp_path: Path, text: str, name: str = "synthetic.xodr") -> Path:
    """Write ``text`` to ``tmp_path/name`` and return the path."""
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def two_road_chain() -> str:
    """Road 1 (a 100 m line along +x) followed by road 2 (a 50 m left arc of radius 100 m)."""
    first = road_xml("1", 100.0, '<geometry s="0" x="0" y="0" hdg="0" length="100"><line/>'
                     "</geometry>",
                     links='<successor elementType="road" elementId="2" contactPoint="start"/>',
                     lane_links=True)
    second = road_xml("2", 50.0, '<geometry s="0" x="100" y="0" hdg="0" length="50">'
                      '<arc curvature="0.01"/></geometry>',
                      links='<predecessor elementType="road" elementId="1" contactPoint="end"/>',
                      lane_links=True)
    return opendrive(first, second)
