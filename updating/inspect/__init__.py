"""The verdict on a re-test: change model, its fit, the MSSO map, the verdict."""
