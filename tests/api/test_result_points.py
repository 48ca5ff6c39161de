"""Result's summary line tells unlocated special points from located ones."""

import json

from contin.api.result import load


def test_the_summary_line_counts_unlocated_points_apart(tmp_path):
    (tmp_path / "summary.json").write_text(json.dumps(
        {"status": "complete", "scene": {"analysis": {"type": "frequency_response", "parameter": "w"}}}))
    (tmp_path / "special_points.csv").write_text(
        "branch,kind,w,index,interval_lo,interval_hi,located,detail\n"
        "0,pd,0.5,1,0.49,0.51,false,location did not converge in 60 iterations\n"
        "0,pd,0.7,3,0.69,0.71,true,located\n"
        "0,fold,0.8,4,0.8,0.8,true,located\n")
    result = load(tmp_path)
    assert [p.located for p in result.special_points] == [False, True, True]
    assert "special points: 2 pd (1 not located), 1 fold>" in repr(result)
