"""Guidance for attitude slews (SEEDS §004 stage 1): the program trajectory and the law that tracks it."""
