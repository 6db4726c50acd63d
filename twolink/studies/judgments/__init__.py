"""The judgments: paired claims on many plants, their words, conclusions, regime map, compare."""
