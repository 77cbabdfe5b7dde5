#!/usr/bin/env bash
# city_block with --traffic end to end (issue 18): the same drive as test_city_block.sh with
# moving cars in the streets (oncoming, crossing at the junctions, turning in ahead of the camera;
# doc/sequences.md). The tracker must reject them: >= 95 % of the frames tracked, the loop closed
# at a true revisit with the map's true scale drift (loop_checks.py), and the corrected trajectory
# within the bound without traffic, 0.5 % of the path (ATE after Sim(3) alignment). Also checks
# that the traffic is there: the rendered description counts the moving cars. ~30 s.
SDS_CITY_TRAFFIC=1 exec bash "$(dirname "${BASH_SOURCE[0]}")/test_city_block.sh"
