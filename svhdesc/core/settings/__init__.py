"""svhdesc/core/settings"""
