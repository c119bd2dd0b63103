"""A zoo of robot identification data that physid did not make, and the robotics recipe.

``cases`` builds the records (other simulators, real logs), ``recipe`` is the practitioners'
pipeline written from numpy, scipy and pinocchio alone, ``compare`` fits every record with
physid's methods and with the recipe and prints one table. See README.md in this folder.
"""
