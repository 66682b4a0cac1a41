"""The gallery of issue 12: the paper's figures as named scenes and trajectory recipes,
drawn in the paper's layout with verdicts computed from the numbers (README "Gallery")."""
