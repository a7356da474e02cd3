"""Design studies: study files, the optimisation problem and its solves, reports, batch studies on Dask."""
