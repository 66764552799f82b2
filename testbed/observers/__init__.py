"""State observers shared by several systems (each with the stage that runs it in testbed.stages)."""
