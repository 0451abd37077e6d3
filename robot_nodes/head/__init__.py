"""The head behaviour: HeadMode in, head goals (through the HCM) out; ball search and tracking, looks at the goal."""
