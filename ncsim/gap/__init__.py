"""Sim-to-real gap diagnosis: measured traces -> alignment -> effects -> fits -> diagnosis."""
