"""The bench table prints (quick mode): every row has samples; ratios refer to rows in the table."""
from bench.__main__ import format_table


def test_table_formats_medians_and_ratios():
    rows = [
        {"name": "ours", "unit": "ms", "samples": [1.0, 1.0, 2.0], "baseline": "naive"},
        {"name": "naive", "unit": "ms", "samples": [4.0, 4.0, 5.0]},
        {"name": "slow", "unit": "us", "samples": [8.0], "baseline": "naive"},
    ]
    text = format_table(rows)
    assert "4.00x faster than 'naive'" in text
    assert "2.00x the time of 'naive'" in text
    assert "1.000ms" in text
