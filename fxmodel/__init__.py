"""The bit-exact fixed-point golden model of the bump-mapping pipeline (Ernst et al., EGGH 1995); numpy only."""
