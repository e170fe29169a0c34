//! defender-report: the paper's tables and plots from run directories (being built).
