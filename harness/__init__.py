"""rsmbench.harness — everything that runs things: Warp kernels, certified queries,
the MuJoCo driver, the benchmark runner, reports and the CLI."""

__all__: list[str] = []
