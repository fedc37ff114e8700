"""Exports of scenarios for other people's tools (``scenweave export``): the in-situ scenario
of a mined event for plain esmini and for CARLA (``scenweave.exports.in_situ``)."""
