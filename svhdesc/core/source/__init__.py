"""svhdesc/core/source"""
