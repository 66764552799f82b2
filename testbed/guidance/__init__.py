"""Guidance for attitude slews (SEEDS §004 stage 1): program trajectory, tracking law, CMG momentum envelope."""
