"""Result files and figures: CSV and JSON streams, the resume checkpoint, plots.
"""
