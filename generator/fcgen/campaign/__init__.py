"""The paper's experiment at scale: the grid, compiled solvers (cached), one task function, executors, Parquet rows."""
