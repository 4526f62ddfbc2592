"""`fcgen report`: the paper's tables and figures from campaign results."""
