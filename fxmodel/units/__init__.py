"""The units of the pipeline, one parameter object each (paper sections 3.2, 4, 4.1), and their exact oracles."""
